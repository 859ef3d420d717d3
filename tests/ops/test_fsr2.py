"""The FSR2-class reference upscaler (``ops.fsr2``): each step on inputs whose answer is known,
and a static camera accumulating to what its jittered samples allow."""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.metrics.psnr import psnr
from mnss_kit.ops import fsr2
from mnss_kit.ops.jitter import jitter_sequence
from mnss_kit.ops.taau import bicubic_upsample

H, W = 6, 8


def _still(depth=0.5):
    return np.full((H, W, 1), depth, np.float32), np.zeros((H, W, 2), np.float32)


def test_dilation_gives_each_pixel_the_nearest_neighbours_motion():
    depth, motion = _still()
    depth[2, 3] = 0.1  # a one-pixel foreground object moving left
    motion[2, 3] = (-1.5, 0.0)
    dilated_depth, dilated_motion = fsr2.dilate(depth, motion)
    assert np.all(dilated_depth[1:4, 2:5] == np.float32(0.1)) and np.all(dilated_motion[1:4, 2:5, 0] == -1.5)
    assert dilated_depth[0, 0, 0] == np.float32(0.5) and np.all(dilated_motion[0, 0] == 0)


def test_dilation_crosses_edges_not_slopes():
    depth, motion = _still()
    depth[:] += 0.01 * np.arange(H)[:, None, None]  # a floor: each row 2% nearer than the next
    motion[..., 1] = np.arange(H)[:, None] * 0.5  # whose motion changes by row
    depth[2, 3], motion[2, 3] = 0.1, (-1.5, 0.0)  # and a near object
    dilated_depth, dilated_motion = fsr2.dilate(depth, motion, edge=0.05)
    assert np.all(dilated_motion[1:4, 2:5, 0] == -1.5)  # across the object's edge
    np.testing.assert_array_equal(dilated_motion[:, 6:], motion[:, 6:])  # the floor keeps its own motion
    np.testing.assert_array_equal(dilated_depth[:, 6:], depth[:, 6:])


def test_previous_depth_is_the_nearest_surface_scattered_along_the_motion():
    depth, motion = _still()
    depth[2, 3] = 0.1
    motion[2, 3] = (2.0, 0.0)  # was two pixels to the right (integer motion: one receiving texel)
    previous = fsr2.reconstruct_previous_depth(depth, motion)
    assert previous[2, 5, 0] == pytest.approx(0.1, abs=1e-6)  # 2 - (2 - d) in float32
    assert previous[2, 2, 0] == pytest.approx(0.5, abs=1e-6)  # the still background lands where it is
    assert previous[2, 3, 0] == fsr2.NO_DEPTH  # nothing seen this frame was there
    far = fsr2.reconstruct_previous_depth(depth, np.full((H, W, 2), 50.0, np.float32))
    assert np.all(far == fsr2.NO_DEPTH)  # everything came from off-screen: no evidence, no clip


def test_depth_clip_flags_the_uncovered_background_only():
    """A near box moved right by two pixels: the background it uncovered (where it was last
    frame) is clipped; the box, the rest of the background and a steep slope are not."""
    params = fsr2.FSR2Params()
    depth, motion = _still()
    depth[:] += 0.03 * np.arange(W)[None, :, None]  # a slope: its own steps are no disocclusion
    depth[2:4, 4:6] = 0.1
    motion[2:4, 4:6] = (-2.0, 0.0)  # the box was two pixels to the left
    dilated_depth, dilated_motion = fsr2.dilate(depth, motion)
    previous = fsr2.reconstruct_previous_depth(dilated_depth, dilated_motion)
    clip = fsr2.disocclusion(dilated_depth, dilated_motion, previous, params)[..., 0]
    assert np.all(clip[2:4, 2] == 1.0)  # where the box was and is no more
    assert np.all(clip[2:4, 3:7] == 0.0) and np.all(clip[0] == 0.0) and np.all(clip[5] == 0.0)


def test_thin_features_are_one_pixel_ridges():
    colour = np.full((H, W, 3), 0.2, np.float32)
    colour[:, 3] = 0.9  # a one-pixel vertical line
    colour[4:, 6:] = 0.6  # a wide edge: no ridge
    thin = fsr2.thin_features(colour, 0.04)[..., 0]
    assert np.all(thin[:, 3] == 1.0) and thin.sum() == H


def test_a_sample_on_a_pixel_centre_is_taken_with_full_weight():
    rng = np.random.default_rng(0)
    current = rng.random((H, W, 3), dtype=np.float32)
    jitter = (0.25, -0.25)  # x2: samples land on HR centres (2j + 1.5, 2i + 0.5)
    samples, weight = fsr2.reconstruct_samples(current, jitter, 2, kernel_width=0.6)
    np.testing.assert_allclose(samples[0::2, 1::2], current, atol=1e-6)
    np.testing.assert_allclose(weight[0::2, 1::2], 1.0, atol=1e-6)
    assert np.all(weight[1::2, 0::2] < 0.01)  # a whole HR pixel away on both axes: the kernel's tails
    upsampled = fsr2.lanczos_upsample(current, jitter, 2)
    np.testing.assert_allclose(upsampled[0::2, 1::2], current, atol=1e-6)  # Lanczos interpolates
    for scale in (2, 3):
        flat = np.full((H, W, 3), 0.3, np.float32)
        np.testing.assert_allclose(fsr2.lanczos_upsample(flat, (0.1, 0.4), scale), 0.3, atol=1e-6)
        np.testing.assert_allclose(fsr2.reconstruct_samples(flat, (0.1, 0.4), scale)[0], 0.3, atol=1e-6)


def test_the_kernel_reaches_as_far_as_fsr2s():
    """FSR 2 scales LR offsets by min(1.99, scale) before its Lanczos-2: the first zero lies about an
    HR pixel away at x2 and 1.5 at x3, unless a width is set."""
    params = fsr2.FSR2Params()
    assert params.kernel_width_at(2) == pytest.approx(2 / 1.99)
    assert params.kernel_width_at(3) == pytest.approx(3 / 1.99)
    assert fsr2.FSR2Params(kernel_width=0.6).kernel_width_at(3) == pytest.approx(0.6)
    with pytest.raises(ValueError):
        fsr2.FSR2Params(kernel_width=0.0)


def test_rcas_sharpens_without_leaving_the_range():
    rng = np.random.default_rng(1)
    image = rng.random((9, 9, 3), dtype=np.float32)
    out = fsr2.rcas(image, 1.0)
    assert out.min() >= 0.0 and out.max() <= 1.0
    assert np.array_equal(fsr2.rcas(image, 0.0), image)
    step = np.full((4, 8, 3), 0.2, np.float32)
    step[:, 4:] = 0.6
    sharpened = fsr2.rcas(step, 1.0)
    assert sharpened[0, 4, 0] > 0.62 and 0.0 < sharpened[0, 3, 0] < 0.18  # both sides of the edge steepen
    black = step.copy()
    black[:, :4] = 0.0
    assert np.array_equal(fsr2.rcas(black, 1.0)[:, 3:5], black[:, 3:5])  # next to black any lobe could clip


def _frame(rng, h=H, w=W):
    return (rng.random((h, w, 3), dtype=np.float32), rng.random((h, w, 1), dtype=np.float32),
            rng.normal(0, 1.5, (h, w, 2)).astype(np.float32), rng.uniform(-0.5, 0.5, 2).astype(np.float32))


def test_a_reset_forgets_the_history_and_the_locks():
    rng = np.random.default_rng(2)
    state = None
    for _ in range(3):
        _, state = fsr2.fsr2_frame(*_frame(rng), state, 2)
    cut = _frame(rng)
    after_cut, cut_state = fsr2.fsr2_frame(*cut, state, 2, reset=True)
    fresh, fresh_state = fsr2.fsr2_frame(*cut, None, 2)
    np.testing.assert_array_equal(after_cut, fresh)
    np.testing.assert_array_equal(cut_state.locks, fresh_state.locks)


def test_a_full_reactive_mask_ignores_the_history():
    rng = np.random.default_rng(3)
    _, state = fsr2.fsr2_frame(*_frame(rng), None, 2)
    frame = _frame(rng)
    reactive, _ = fsr2.fsr2_frame(*frame, state, 2, reactive=np.ones((H, W, 1), np.float32))
    fresh, _ = fsr2.fsr2_frame(*frame, None, 2)
    np.testing.assert_allclose(reactive, fresh, atol=1e-6)


def _pattern(x, y):
    """Detail near the HR Nyquist limit (HR pixel units), as tests/eval's panning sequence."""
    return np.stack([0.5 + 0.35 * np.sin(0.9 * x + 0.3 * y), 0.5 + 0.35 * np.cos(0.7 * y - 0.2 * x) * np.sin(0.25 * x),
                     0.5 + 0.3 * np.sign(np.sin(0.45 * x) * np.sin(0.45 * y))], axis=-1).astype(np.float32)


def _static_psnr(pattern: str, frames: int = 16, params: fsr2.FSR2Params = fsr2.FSR2Params()):
    """A still 24x16 -> 48x32 view, ``frames`` frames: PSNR against the 16-sample box reference of
    the last output, of the point-sampled HR frame and of jitter-aware bicubic (centre crop)."""
    h, w, s = 16, 24, 2
    hy, hx = np.meshgrid(np.arange(h * s) + 0.5, np.arange(w * s) + 0.5, indexing="ij")
    point = _pattern(hx, hy)
    reference = np.mean([_pattern(hx - 0.5 + (k % 4 + 0.5) / 4, hy - 0.5 + (k // 4 + 0.5) / 4) for k in range(16)], axis=0)
    depth, motion = np.full((h, w, 1), 0.5, np.float32), np.zeros((h, w, 2), np.float32)
    state = None
    for jitter in jitter_sequence(pattern, s, frames).astype(np.float32):
        ly, lx = np.meshgrid(np.arange(h) + 0.5 + jitter[1], np.arange(w) + 0.5 + jitter[0], indexing="ij")
        colour = _pattern(lx * s, ly * s)
        output, state = fsr2.fsr2_frame(colour, depth, motion, jitter, state, s, params)
    inner = (slice(4, -4), slice(4, -4))  # away from the clamped edges
    bicubic = np.clip(bicubic_upsample(colour, jitter, s), 0, 1)
    return psnr(output[inner], reference[inner]), psnr(point[inner], reference[inner]), psnr(bicubic[inner], reference[inner])


def test_a_static_camera_converges_to_what_its_samples_allow():
    """MNSS jitter gives one sample at every HR pixel centre each four frames: the output comes
    within 1 dB of that point-sampled HR frame against the 16-sample reference (45.0 dB against
    45.2 when this was written) and far above bicubic."""
    converged, point, bicubic = _static_psnr("grid")
    assert converged > point - 1.0
    assert converged > bicubic + 10.0


def test_a_static_camera_accumulates_halton_samples():
    """Halton samples land anywhere.  With FSR 2's kernel, about an HR pixel wide, the accumulation
    gains >8 dB on bicubic in sixteen frames, though it softens this pattern's hard edges (28.8 dB
    against 19.3 when this was written); a kernel of 0.6 HR pixels keeps them (38.2 dB)."""
    converged, _, bicubic = _static_psnr("halton")
    narrow, _, _ = _static_psnr("halton", params=fsr2.FSR2Params(kernel_width=0.6))
    assert converged > bicubic + 8.0
    assert narrow > converged + 5.0


def test_a_bad_input_frame_leaves_every_later_output_finite():
    """A frame of NaN colour, Inf depth and NaN motion leaves every later output and history finite.
    (On this still, converged pattern the sanitized black block stays in the locked history for
    several frames: recovery within two frames is not claimed for fsr2.)"""
    from mnss_kit.ops.fsr2 import fsr2_frame

    rng = np.random.default_rng(21)
    colour = rng.random((8, 10, 3), dtype=np.float32)
    depth = np.full((8, 10, 1), 0.5, np.float32)
    motion = np.zeros((8, 10, 2), np.float32)
    jitters = [(0.25, -0.25), (-0.25, 0.25), (0.25, 0.25), (-0.25, -0.25)] * 2
    clean, faulty = None, None
    for t, jitter in enumerate(jitters):
        bad = t == 3
        c, d, m = colour.copy(), depth.copy(), motion.copy()
        if bad:
            c[2:5, 2:6] = np.nan
            d[0:3] = np.inf
            m[4:6] = np.nan
        want, clean = fsr2_frame(colour, depth, motion, np.array(jitter), clean, 2)
        got, faulty = fsr2_frame(c, d, m, np.array(jitter), faulty, 2)
        assert np.isfinite(got).all() and np.isfinite(faulty.history).all()
    assert not np.array_equal(got, want)  # the fault did reach the output
