"""Window runner: ground-truth history, truncated backpropagation, validation."""

from __future__ import annotations

import torch
from torch import nn

from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model
from mnss_kit.train.config import TrainConfig
from mnss_kit.train.distributed import World
from mnss_kit.model.mnss.loss import MNSSLoss
from mnss_kit.train.run import _step
from mnss_kit.train.recurrent import WindowChunk, crop_validity, validate

from train_helpers import TINY_MODEL


class StateSpy(nn.Module):
    """The real model, remembering the history it was given at every frame."""

    def __init__(self):
        super().__init__()
        torch.manual_seed(0)
        self.inner = build_model(MNSSConfig(**TINY_MODEL))
        self.scale, self.config = self.inner.scale, self.inner.config
        self.seen: list[torch.Tensor] = []
        self.outputs: list[torch.Tensor] = []

    def initial_state(self, frame):
        return self.inner.initial_state(frame)

    def forward(self, frame, state):
        self.seen.append(state["history"])
        output, aux, state = self.inner(frame, state)
        self.outputs.append(output)
        return output, aux, state


def _batch(n=2, t=4, h=8, w=8, seed=0):
    g = torch.Generator().manual_seed(seed)
    reset = torch.zeros(n, t)
    reset[:, 0] = 1.0
    return {
        "color": torch.rand(n, t, 3, h, w, generator=g),
        "depth": torch.rand(n, t, 1, h, w, generator=g),
        "motion": torch.randn(n, t, 2, h, w, generator=g),
        "jitter": torch.rand(n, t, 2, generator=g) - 0.5,
        "reset": reset,
        "reference": torch.rand(n, t, 3, 2 * h, 2 * w, generator=g),
    }


def test_ground_truth_history_replaces_the_previous_output():
    batch = _batch()
    for gt_history in (True, False):
        spy = StateSpy()
        chunk = WindowChunk(spy, MNSSLoss(2))
        chunk(batch, 0, 4, spy.initial_state({k: v[:, 0] for k, v in batch.items()}), None, gt_history, 4)
        for t in range(1, 4):
            expected = batch["reference"][:, t - 1] if gt_history else spy.outputs[t - 1]
            assert torch.equal(spy.seen[t], expected)


def test_truncated_bptt_detaches_every_k_frames():
    batch = _batch(t=5)
    spy = StateSpy()
    optimizer = torch.optim.Adam(spy.parameters())
    cfg = TrainConfig(window=5, bptt=2, gt_history_epochs=0)
    _step(cfg, 0, spy, optimizer, WindowChunk(spy, MNSSLoss(2)), batch, World())
    attached = [h.requires_grad for h in spy.seen]
    assert attached == [False, True, False, True, False]  # fresh state, then cut at frames 2 and 4


def test_burn_in_frames_build_history_without_gradient():
    batch = _batch(t=5)
    spy = StateSpy()
    optimizer = torch.optim.Adam(spy.parameters())
    cfg = TrainConfig(window=3, burn_in=2, gt_history_epochs=0)
    _step(cfg, 0, spy, optimizer, WindowChunk(spy, MNSSLoss(2)), batch, World())
    assert len(spy.seen) == 5
    assert not spy.outputs[1].requires_grad and spy.outputs[2].requires_grad  # burn-in: no graph
    assert torch.equal(spy.seen[2], spy.outputs[1])  # the first frame with loss continues the burned-in history


def test_step_updates_weights_and_returns_terms():
    batch = _batch()
    spy = StateSpy()
    before = [p.detach().clone() for p in spy.parameters()]
    optimizer = torch.optim.Adam(spy.parameters(), lr=1e-2)
    terms = _step(TrainConfig(window=4), 0, spy, optimizer, WindowChunk(spy, MNSSLoss(2)), batch, World())
    assert terms.shape == (len(MNSSLoss.terms),) and torch.isfinite(terms).all() and terms[0] > 0
    assert any(not torch.equal(a, b) for a, b in zip(before, spy.parameters()))


def test_validate_reports_psnr_and_images():
    batch = _batch(n=1, h=12, w=12)
    windows = [{k: v[0] for k, v in batch.items()}]
    model = StateSpy().inner
    scalars, images = validate(model, windows, [0])
    assert set(scalars) == {"val/psnr", "val/psnr_upsampled"} and 0 < scalars["val/psnr"] < 60
    assert images["val/output"].shape == (3, 24, 24) and model.training


def test_crop_validity_follows_history_leaving_the_crop():
    n, h, w = 1, 6, 8
    frame = {"color": torch.zeros(n, 3, h, w), "motion": torch.zeros(n, 2, h, w), "reset": torch.zeros(n)}
    valid = crop_validity(None, frame, 2)
    assert valid.shape == (1, 1, 12, 16) and valid.all()
    still = crop_validity(valid, frame, 2)
    assert still[0, 0, 1:-1, 1:-1].all() and not still[0, 0, 0].any()  # only the clamped outer ring is lost
    frame["motion"][:, 0] = 1.0  # surfaces move left: history comes from 2 HR pixels to the right
    moving = valid
    for _ in range(3):
        moving = crop_validity(moving, frame, 2)
    assert moving[0, 0, 3, :9].all() and not moving[0, 0, 3, 10:].any()
    frame["reset"][:] = 1.0
    assert crop_validity(moving, frame, 2).all()  # a reset frame needs no history


def test_masked_pixels_carry_no_gradient():
    batch = _batch(t=2)
    spy = StateSpy()
    chunk = WindowChunk(spy, MNSSLoss(2))
    state = spy.initial_state({k: v[:, 0] for k, v in batch.items()})
    valid = torch.zeros(2, 1, 16, 16, dtype=torch.bool)
    batch["reset"][:] = 0.0
    batch["motion"][:] = 100.0  # every pixel's history comes from far outside the crop
    loss, terms, _, valid = chunk(batch, 0, 2, state, valid, False, 2)
    assert not valid.any() and float(terms[1]) < 1e-6  # the SSIM term sees output == reference
