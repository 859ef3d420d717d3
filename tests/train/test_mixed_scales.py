"""Training on several scales (issue 44): windows grouped by scale, one scale per batch, a step
stream that resumes exactly, a model that reads the frame key ``scale``, and one-line refusals
for families that train at one scale."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import pytest
import torch
import torch.nn.functional as F
import yaml
from torch import nn

from mnss_kit.dataset.loader import WindowDataset
from mnss_kit.errors import UserError
from mnss_kit.model.families import FAMILIES
from mnss_kit.model.family import Family
from mnss_kit.train.config import load_experiment
from mnss_kit.train.data import StepSampler, step_loader
from mnss_kit.train.run import train
from mnss_kit.train.recurrent import batch_scale, crop_validity

CAMERA = """
keyframes:
  - {time: 0.5, position: [-10, 14, 12], look_at: [-9, 0, 0]}
  - {time: 0.7, position: [-6, 14, 11], look_at: [-4, 0, 0]}
"""
# exact ratios: 48x27 -> 32x18 at 1.5 (3/2), 51x34 -> 30x20 at 1.7 (17/10), 24x14 -> 48x28 at 2
CONFIG = """
version: 1
defaults: {jitter: halton, hr_samples: 1, frames: 3, start_time: 0.5, camera: cam.yaml}
sequences:
  - {name: a15, scene: arena, seed: 11, scale: 1.5, hr_size: [48, 27]}
  - {name: b15, scene: town, seed: 12, scale: 1.5, hr_size: [48, 27]}
  - {name: c17, scene: arena, seed: 13, scale: 1.7, hr_size: [51, 34]}
  - {name: d2, scene: arena, seed: 14, scale: 2, lr_size: [24, 14]}
  - {name: e17, scene: arena, seed: 15, scale: 1.7, hr_size: [80, 45]}
"""
MIXED = ("a15", "b15", "c17", "d2")  # e17: 80x45 -> 47x26 at 1.7 (80/47, 45/26): not exactly 1.7


@pytest.fixture(scope="module")
def mixed_data(tmp_path_factory):
    from mnss_kit.render.config import load_render_config
    from mnss_kit.render.run import render_dataset

    root = tmp_path_factory.mktemp("mixed_scales")
    (root / "cam.yaml").write_text(CAMERA)
    (root / "cfg.yaml").write_text(CONFIG)
    render_dataset(load_render_config(str(root / "cfg.yaml")), root / "all", progress=False)
    mixed = root / "mixed"
    mixed.mkdir()
    for name in MIXED:
        (mixed / name).symlink_to(root / "all" / name, target_is_directory=True)
    return root


def _windows(root, tmp_path, **kw):
    return WindowDataset(root / "mixed", window=2, crop=12, cache_dir=tmp_path / "cache", progress=False, seed=5,
                         mixed_scales=True, with_scale=True, **kw)


def test_windows_of_a_mixed_dataset_group_by_scale(mixed_data, tmp_path):
    ds = _windows(mixed_data, tmp_path)
    groups = ds.window_groups()
    assert list(groups) == [1.5, 1.7, 2] and ds.scales == [1.5, 1.7, 2] and ds.scale is None
    assert sorted(i for g in groups.values() for i in g) == list(range(len(ds)))
    # the crop of 12 LR pixels on each scale's grid: 12 at 1.5 (step 2), 10 at 1.7 (step 10), 12 at 2
    assert ds.crop_sizes == {1.5: (12, 12), 1.7: (10, 10), 2: (12, 12)}
    hr = {1.5: 18, 1.7: 17, 2: 24}
    for scale, members in groups.items():
        for index in members:
            for epoch in range(3):
                ds.set_epoch(epoch)
                item = ds[index]
                lr = ds.crop_sizes[scale][0]
                assert item["color"].shape == (2, 3, lr, lr) and item["reference"].shape == (2, 3, hr[scale], hr[scale])
                assert torch.equal(item["scale"], torch.full((2,), float(scale)))
                crop = ds.crop_for(index)
                step = 10 if scale == 1.7 else 2 if scale == 1.5 else 1
                assert crop.x % step == 0 and crop.y % step == 0


def test_mixed_scales_need_the_flag_and_exact_ratios(mixed_data, tmp_path):
    with pytest.raises(UserError, match="different scales") as e:
        WindowDataset(mixed_data / "mixed", window=2, crop=12, cache_dir=tmp_path, progress=False)
    assert "\n" not in str(e.value)
    with pytest.raises(UserError, match=r"e17 is 47x26 -> 80x45, not exactly x1.7 .* e\.g\. 85x51 -> 50x30") as e:
        WindowDataset([mixed_data / "mixed", mixed_data / "all" / "e17"], window=2, crop=12, cache_dir=tmp_path,
                      progress=False, mixed_scales=True)
    assert "\n" not in str(e.value)
    # one scale with the flag: as before (the ratio grid is checked, not rounded)
    one = WindowDataset(mixed_data / "all" / "e17", window=2, crop=(47, 26), cache_dir=tmp_path, progress=False,
                        mixed_scales=True, with_scale=True)
    assert one.scale == 1.7 and list(one.window_groups()) == [1.7] and one[0]["scale"].shape == (2,)


def _groups(sizes):
    out, start = [], 0
    for n in sizes:
        out.append(list(range(start, start + n)))
        start += n
    return out


def test_every_step_draws_one_group_the_same_on_every_rank():
    groups = _groups([5, 3, 9])
    batch, world = 3, 2
    streams = [list(StepSampler(17, batch, rank, world, seed=2, start_step=0, end_step=40, groups=groups)) for rank in range(world)]
    step_groups = StepSampler(17, batch, 0, world, seed=2, start_step=0, end_step=40, groups=groups).step_groups(0, 40)
    assert set(step_groups.tolist()) == {0, 1, 2}
    for stream in streams:
        assert len(stream) == 40 * batch
        for s in range(40):
            members = groups[step_groups[s]]
            assert all(index in members for _, index in stream[s * batch:(s + 1) * batch])
    # the ranks read disjoint shards of each pass of a group
    for g, members in enumerate(groups):
        per_rank = [[d for s, d in enumerate(stream) if step_groups[s // batch] == g] for stream in streams]
        first_pass = [{i for p, i in draws if p == 0} for draws in per_rank]
        if len(members) % world == 0:
            assert not first_pass[0] & first_pass[1]


def test_resumed_mixed_stream_equals_the_uninterrupted_one():
    groups = _groups([4, 7, 2])
    for start in (0, 1, 5, 13, 255, 256, 300):
        full = list(StepSampler(13, 4, 1, 2, seed=3, start_step=0, end_step=320, groups=groups))
        tail = list(StepSampler(13, 4, 1, 2, seed=3, start_step=start, end_step=320, groups=groups))
        assert tail == full[start * 4:]
    other = list(StepSampler(13, 4, 1, 2, seed=4, start_step=0, end_step=320, groups=groups))
    assert other != full


def test_one_group_is_the_single_scale_stream():
    plain = list(StepSampler(7, 4, 1, 2, seed=0, start_step=3, end_step=9))
    assert list(StepSampler(7, 4, 1, 2, seed=0, start_step=3, end_step=9, groups=[list(range(7))])) == plain


def test_loader_batches_hold_one_scale_and_resume_exactly(mixed_data, tmp_path):
    experiment = _experiment(mixed_data, tmp_path, {"family": "mnss", "scale": 2}, total_steps=8)
    ds = _windows(mixed_data, tmp_path)
    full = list(step_loader(ds, experiment.train, 0, 1, 0))
    assert len(full) == 8
    seen = set()
    for batch in full:
        seen.add(batch_scale(batch, None))
        assert batch["scale"].shape == (2, 2)
    assert len(seen) > 1 and seen <= {1.5, 1.7, 2}  # 1.7, not its float32 1.70000005
    tail = list(step_loader(ds, experiment.train, 0, 1, 5))
    for a, b in zip(full[5:], tail):
        assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_crop_validity_at_a_fractional_scale():
    frame = {"color": torch.zeros(1, 3, 10, 10), "motion": torch.zeros(1, 2, 10, 10), "reset": torch.zeros(1)}
    valid = crop_validity(None, frame, 1.7, (17, 17))
    valid = crop_validity(valid, frame, 1.7, (17, 17))
    assert valid.shape == (1, 1, 17, 17) and bool(valid[0, 0, 8, 8]) and not bool(valid[0, 0, 0, 0])


# a family that takes any scale: bilinear to LR x s (the batch's frame key 'scale') plus a conv
SEEN_SCALES: list[list[float]] = []


@dataclass
class ScaledConfig:
    family: Literal["scaled"] = "scaled"
    scale: int = 2
    width: int = 4


class Scaled(nn.Module):
    takes_frame_scale = True

    def __init__(self, config: ScaledConfig):
        super().__init__()
        self.config, self.scale = config, config.scale
        self.net = nn.Sequential(nn.Conv2d(3, config.width, 3, padding=1), nn.ReLU(), nn.Conv2d(config.width, 3, 3, padding=1))

    def stages(self):
        return [("net", self.net, "npu")]

    def initial_state(self, frame):
        return {}

    def forward(self, frame, state=None):
        scale = frame.get("scale", self.scale)
        s = round(float(scale[0]), 3) if torch.is_tensor(scale) else float(scale)
        if "scale" in frame and SEEN_SCALES:  # the training loop's frames (not the MAC count's example frame)
            SEEN_SCALES[-1].append(s)
        h, w = frame["color"].shape[-2:]
        up = F.interpolate(frame["color"], size=(round(h * s), round(w * s)), mode="bilinear", align_corners=False)
        return up + self.net(up), {}, {}


class L1(nn.Module):
    terms = ("total", "l1")
    flicker_weight = 0.0

    def forward(self, output, aux, frame, reference, valid=None, flicker=None):
        l1 = F.l1_loss(output, reference)
        return {"total": l1, "l1": l1}


SCALED_FAMILY = Family(name="scaled", config=ScaledConfig, build=Scaled, loss=lambda config, train: L1(),
                       lr_inputs=("color",), npu_stages=("net",), gpu_plan=lambda *a: {}, fixed_macs=lambda c: {},
                       learned_prefixes=("net",))


def _experiment(root, tmp_path, model: dict, **train_changes):
    doc = {"schema": 1, "model": model, "train": {
        "train_data": str(root / "mixed"), "window": 2, "batch_size": 2, "crop": 12, "total_steps": 3,
        "gt_history_epochs": 0, "threads": 1, "log_every": 1, "checkpoint_every": 2, "val_every": 0,
        "cache_dir": str(tmp_path / "cache"), **train_changes}}
    path = tmp_path / "experiment.yaml"
    path.write_text(yaml.safe_dump(doc))
    return load_experiment(path)[0]


def test_three_steps_on_mixed_data_call_the_model_at_each_batch_scale(mixed_data, tmp_path, monkeypatch):
    from mnss_kit.model import checkpoint

    monkeypatch.setitem(FAMILIES, "scaled", SCALED_FAMILY)
    experiment = _experiment(mixed_data, tmp_path, {"family": "scaled", "scale": 2})
    SEEN_SCALES.clear()
    SEEN_SCALES.append([])
    out = train(experiment, tmp_path / "run", progress=False)
    calls = SEEN_SCALES[-1]  # one call per frame: 3 steps x 2 frames
    assert len(calls) == 6
    ds = _windows(mixed_data, tmp_path)
    groups = list(ds.window_groups())
    expected = StepSampler(len(ds), 2, 0, 1, 0, 0, 3, list(ds.window_groups().values())).step_groups(0, 3)
    assert calls == [float(groups[g]) for g in expected for _ in range(2)]
    _, record = checkpoint.load(out)
    assert record["train_scales"] == [1.5, 1.7, 2] and record["scale"] == 2


@pytest.mark.parametrize("model", [{"family": "mnss", "scale": 2, "recon_width": 8, "recon_layers": 2, "aa_width": 4, "aa_layers": 1},
                                   {"family": "ntaau", "scale": 2}])
def test_families_of_one_scale_refuse_mixed_data_in_one_line(mixed_data, tmp_path, model):
    experiment = _experiment(mixed_data, tmp_path, model)
    with pytest.raises(UserError, match=r"training data mixes scales x1\.5, x1\.7, x2, but the \w+ family trains at one "
                                         r"scale \(x2;") as e:
        train(experiment, tmp_path / "run", progress=False)
    assert "\n" not in str(e.value)
    assert not (tmp_path / "cache").exists()  # refused before the decoded cache is built
