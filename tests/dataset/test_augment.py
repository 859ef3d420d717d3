"""Training augmentations (``dataset/augment.py``): per-window draws that do not depend on the
loader, each degradation as the matching input variant makes it, and a clear error for bad settings."""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.config import from_dict
from mnss_kit.dataset import augment as aug
from mnss_kit.dataset import engine_motion as em
from mnss_kit.dataset.format import read_meta
from mnss_kit.dataset.loader import WindowDataset
from mnss_kit.errors import UserError
from mnss_kit.ops import colour
from mnss_kit.train.config import TrainConfig


def windows(root, tmp_path, augment=None):
    return WindowDataset(root, 3, (16, 16), seed=1, cache=False, progress=False, augment=augment)


def test_a_window_is_augmented_the_same_way_on_every_read(synthetic_dataset, tmp_path):
    plain = windows(synthetic_dataset, tmp_path)
    every = windows(synthetic_dataset, tmp_path, {"ldr8": 1.0, "motion_noise": 1.0})
    never = windows(synthetic_dataset, tmp_path, {"ldr8": 0.0, "motion_noise": 0.0})
    a, b, base = every[2], every[2], plain[2]
    assert all(np.array_equal(a[k], b[k]) for k in a)  # drawn from (seed, epoch, index), not the reader
    assert all(np.array_equal(never[2][k], base[k]) for k in base)
    codes = a["color"].numpy() * 255.0
    assert np.allclose(codes, np.round(codes), atol=1e-3) and not np.array_equal(a["color"], base["color"])
    noise = (a["motion"] - base["motion"]).numpy()
    assert 0.15 < noise.std() < 0.35  # variants.MOTION_NOISE_PX = 0.25 px
    assert np.array_equal(a["reference"], base["reference"])  # the target is never degraded
    every.set_epoch(1)
    assert not np.array_equal(every[2]["motion"], a["motion"])  # a new epoch draws new noise


def test_depth_round_trip_keeps_precision_near_the_camera(synthetic_dataset):
    meta = read_meta(synthetic_dataset / "pan")
    depth = np.linspace(0.0, 1.0, 1001, dtype=np.float32)
    d8, d16 = aug.requantized_depth(depth, meta, 8), aug.requantized_depth(depth, meta, 16)
    assert np.abs(d16 - depth).max() < np.abs(d8 - depth).max()
    near = depth < 0.05
    assert np.abs(d8 - depth)[near].max() < np.abs(d8 - depth)[~near].max()  # reversed depth: finest near
    assert np.all(np.diff(d8) >= 0)  # monotonic: depth order survives


def test_exposure_scales_the_light_of_colour_reference_and_emission(monkeypatch):
    rng = np.random.default_rng(0)
    linear = rng.uniform(0.0, 3.0, (2, 3, 4, 4)).astype(np.float32)
    arrays = {"color": colour.to_display(linear), "reference": colour.to_display(linear * 2), "hr_emissive": linear.copy()}
    monkeypatch.setattr(aug, "draw", lambda augment, rng: ["exposure"])
    out = aug.augment_window(arrays, None, {"exposure": 1.0}, np.random.default_rng(3))
    k = out["hr_emissive"] / linear
    assert np.allclose(k, k.flat[0]) and 0.5 <= k.flat[0] <= 2.0
    assert np.allclose(colour.from_display(out["color"]), linear * k.flat[0], rtol=2e-3, atol=1e-3)
    assert np.allclose(colour.from_display(out["reference"]), 2 * linear * k.flat[0], rtol=2e-3, atol=1e-3)


def test_one_depth_precision_per_window():
    rng = np.random.default_rng(0)
    assert all(not {"depth8", "depth16"} <= set(aug.draw({"depth8": 1.0, "depth16": 1.0}, rng)) for _ in range(20))


@pytest.mark.parametrize("augment,message", [({"ldr9": 0.5}, "unknown augmentation 'ldr9'"),
                                             ({"ldr8": 1.5}, r"augment.ldr8 is a probability in \[0, 1\]")])
def test_bad_augment_settings_are_named(augment, message):
    with pytest.raises(UserError, match=message):
        from_dict(TrainConfig, {"augment": augment})


def test_engine_motion_augmentations_apply_the_variants_definitions_per_frame():
    rng = np.random.default_rng(1)
    motion = rng.uniform(-4.0, 4.0, (3, 2, 6, 8)).astype(np.float32)
    depth = rng.uniform(0.0, 1.0, (3, 1, 6, 8)).astype(np.float32)
    arrays = {"motion": motion, "depth": depth}
    for name, expected in (("motion_dilate", lambda m, d: em.dilated(m, d)), ("motion_pack8", lambda m, d: em.packed8(m)),
                           ("motion_half", lambda m, d: em.half_float(m))):
        out = aug.augment_window(arrays, None, {name: 1.0}, np.random.default_rng(0))
        for t in range(3):
            want = expected(motion[t].transpose(1, 2, 0), depth[t].transpose(1, 2, 0)).transpose(2, 0, 1)
            np.testing.assert_array_equal(out["motion"][t], want)
    assert all(not {"motion_pack8", "motion_half"} <= set(aug.draw({"motion_pack8": 1.0, "motion_half": 1.0}, rng))
               for _ in range(20))
