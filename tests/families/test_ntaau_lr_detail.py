"""ntaau_lr's ``detail`` study option: the luma patch is a pixel shuffle at x2 and a continuous
patch at other scales, a model started from a checkpoint without it is that checkpoint, and a bundle
refuses it (the GPU passes do not draw it)."""

from __future__ import annotations

import pytest
import torch

from mnss_kit.errors import UserError
from mnss_kit.model import checkpoint
from mnss_kit.model.config import model_config_from_dict
from mnss_kit.model.families import build_model
from mnss_kit.model.family import example_frame
from mnss_kit.model.families import FAMILIES
from mnss_kit.model.ntaau_lr.config import NTAAULRConfig
from mnss_kit.model.ntaau_lr.gpu_plan import bundle_gpu_plan
from mnss_kit.model.ntaau_lr.net import detail_luma
from mnss_kit.train.init import initial_weights


def test_at_x2_each_hr_pixel_takes_one_patch_value():
    raw = torch.randn(2, 4, 5, 7, generator=torch.Generator().manual_seed(1))
    want = torch.nn.functional.pixel_shuffle(0.1 * torch.tanh(raw), 2)
    assert torch.allclose(detail_luma(raw, (10, 14), 0.1), want, atol=1e-7)


def test_at_a_fractional_scale_a_flat_patch_draws_a_flat_value():
    raw = torch.full((1, 4, 6, 8), 0.5)
    out = detail_luma(raw, (9, 12), 0.2)  # 1.5x
    assert out.shape == (1, 1, 9, 12)
    assert torch.allclose(out, torch.full_like(out, 0.2 * torch.tanh(torch.tensor(0.5))), atol=1e-7)


def test_a_detail_model_from_a_checkpoint_without_it_is_that_checkpoint():
    shipped, record = checkpoint.load("ntaau_lr_x2")
    config = model_config_from_dict(record["config"] | {"detail": True})
    weights, _ = initial_weights(config, "ntaau_lr_x2")
    model = build_model(config)
    model.load_state_dict(weights)
    g = torch.Generator().manual_seed(4)
    frames = [example_frame(FAMILIES["ntaau_lr"], 12, 16, 2, generator=g) for _ in range(3)]
    state = ref_state = None
    with torch.no_grad():
        for frame in frames:
            out, _, state = model(frame, state)
            ref, _, ref_state = shipped(frame, ref_state)
            assert torch.allclose(out, ref, atol=1e-6)


def test_a_bundle_refuses_a_detail_model():
    with pytest.raises(UserError, match="torch-only"):
        bundle_gpu_plan(NTAAULRConfig(detail=True), {}, (16, 12), {}, "generic")
