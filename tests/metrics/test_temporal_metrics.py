import math

import numpy as np
import pytest

from mnss_kit.metrics.temporal import TemporalMasks, if_ssim, shading_threshold, temporal_error, temporal_masks

H, W = 48, 64


def texture(rng_seed=0):
    rng = np.random.default_rng(rng_seed)
    y, x = np.mgrid[0:H, 0:W]
    base = 0.5 + 0.3 * np.sin(x * 0.4)[..., None] * np.cos(y * 0.3)[..., None] * np.array([1.0, 0.8, 0.6])
    return np.clip(base + rng.normal(0, 0.02, (H, W, 3)), 0, 1).astype(np.float32)


def static_masks(ref):
    depth = np.full((H, W, 1), 0.5, np.float32)
    return temporal_masks(ref, ref, depth, depth, np.zeros((H, W, 2), np.float32))


def test_static_sequence_has_if_ssim_one_and_zero_error():
    ref = texture()
    out = np.clip(ref + np.random.default_rng(5).normal(0, 0.05, ref.shape), 0, 1).astype(np.float32)
    masks = static_masks(ref)
    assert masks.valid.all() or masks.valid[: H - H % 2, : W - W % 2].all()
    assert if_ssim(out, out, masks) == pytest.approx(1.0, abs=1e-6)
    assert temporal_error(out, out, masks) == 0.0


def test_flicker_lowers_if_ssim_and_raises_error():
    ref = texture()
    masks = static_masks(ref)
    rng = np.random.default_rng(7)
    prev = np.clip(ref + rng.normal(0, 0.04, ref.shape), 0, 1).astype(np.float32)
    now = np.clip(ref + rng.normal(0, 0.04, ref.shape), 0, 1).astype(np.float32)
    mild = np.clip(ref + rng.normal(0, 0.01, ref.shape), 0, 1).astype(np.float32)
    assert if_ssim(now, prev, masks) < if_ssim(mild, ref, masks) < 1.0
    assert if_ssim(now, prev, masks) < 0.98  # MNSS reports 0.985 for its own output
    assert temporal_error(now, prev, masks) > 0.02


def test_motion_is_followed():
    """A texture that scrolls by whole pixels, with matching motion, is perfectly stable."""
    big = texture()
    prev, now = big[:, 3:], big[:, :-3]  # content moves 3 px right: now[x] == prev[x - 3]
    motion = np.zeros((H, W - 3, 2), np.float32)
    motion[..., 0] = -3.0
    depth = np.full((H, W - 3, 1), 0.5, np.float32)
    masks = temporal_masks(now, prev, depth, depth, motion)
    assert masks.disoccluded[:, :3].all() and not masks.disoccluded[:, 3:].any()  # left edge is new content
    assert if_ssim(now, prev, masks) == pytest.approx(1.0, abs=1e-6)
    wrong = TemporalMasks(np.zeros_like(motion), masks.disoccluded, masks.shading_changed)
    assert if_ssim(now, prev, wrong) < 0.9


def moving_object_frames():
    """Flat grey image; only depth shows a square that moves 4 px right."""
    depth_prev = np.full((H, W, 1), 0.8, np.float32)
    depth_now = depth_prev.copy()
    depth_prev[10:30, 20:40] = 0.2
    depth_now[10:30, 24:44] = 0.2
    motion = np.zeros((H, W, 2), np.float32)
    motion[10:30, 24:44, 0] = -4.0
    grey = np.full((H, W, 3), 0.5, np.float32)
    return grey, depth_prev, depth_now, motion


def test_disocclusion_mask_marks_revealed_pixels_and_excludes_them():
    grey, depth_prev, depth_now, motion = moving_object_frames()
    masks = temporal_masks(grey, grey, depth_now, depth_prev, motion)
    expected = np.zeros((H, W), bool)
    expected[10:30, 20:24] = True  # background the square uncovered
    np.testing.assert_array_equal(masks.disoccluded, expected)
    assert not masks.shading_changed.any()

    # new content may be anything: garbage in the revealed pixels of frame t is not flicker
    garbage_now = grey.copy()
    garbage_now[expected] = np.random.default_rng(1).random((expected.sum(), 3))
    assert if_ssim(garbage_now, grey, masks) == pytest.approx(1.0, abs=1e-6)
    assert temporal_error(garbage_now, grey, masks) == 0.0
    unmasked = TemporalMasks(motion, np.zeros_like(expected), masks.shading_changed)
    assert if_ssim(garbage_now, grey, unmasked) < 0.99
    assert temporal_error(garbage_now, grey, unmasked) > 0.0


def test_true_shading_change_is_excluded():
    """A light turns on in one region of the reference; an output that follows it is not flicker."""
    ref_prev = texture()
    ref_now = ref_prev.copy()
    ref_now[:, :24] = np.clip(ref_now[:, :24] * 1.5, 0, 1)
    depth = np.full((H, W, 1), 0.5, np.float32)
    masks = temporal_masks(ref_now, ref_prev, depth, depth, np.zeros((H, W, 2), np.float32))
    assert masks.shading_changed[:, : 24 // 2].mean() > 0.9
    assert not masks.shading_changed[:, 24 // 2 + 1 :].any()
    assert if_ssim(ref_now, ref_prev, masks) == pytest.approx(1.0, abs=1e-6)
    none = TemporalMasks(masks.motion, masks.disoccluded, np.zeros_like(masks.shading_changed))
    assert if_ssim(ref_now, ref_prev, none) < 0.99


def test_threshold_rises_with_brightness_and_nan_when_nothing_valid():
    t = shading_threshold(np.array([0.0, 0.5, 1.0]))
    assert t[0] > 0 and t[0] < t[1] < t[2]
    grey = np.full((H, W, 3), 0.5, np.float32)
    everything = TemporalMasks(np.zeros((H, W, 2), np.float32), np.ones((H, W), bool), np.zeros((H // 2, W // 2), bool))
    assert math.isnan(if_ssim(grey, grey, everything))
    assert math.isnan(temporal_error(grey, grey, everything))
