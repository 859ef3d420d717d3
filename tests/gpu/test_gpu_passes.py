"""Every runtime pass on Mesa (EGL) against its numpy reference: float outputs within
FLOAT_ATOL (or one fp16 step above 2), with negative and off-screen motion and every jitter
pattern at scales 2 and 3."""

from __future__ import annotations

import numpy as np
import pytest
from gpu_helpers import FLOAT_ATOL, assert_float_close, pattern_jitters, random_conv, random_frame

from mnss_kit.gpu.reference import to_half
from mnss_kit.ops.jitter import PATTERNS
from mnss_kit.ops.sharpen import unsharp
from mnss_kit.ops.warp import OFFSCREEN_DEPTH

CASES = [(p, s) for p in PATTERNS for s in (2, 3)]
H, W = 5, 7  # LR size: odd, so edge clamping and partial workgroups are exercised


@pytest.mark.parametrize("pattern, scale", CASES)
def test_warp_inpaint_and_blend_match_reference_for_every_jitter(mesa, ref, pattern, scale):
    """Each frame of one period, with the previous frame's jitter as the previous jitter."""
    rng = np.random.default_rng(scale)
    jitters = pattern_jitters(pattern, scale)
    conv = random_conv(rng, 1, 4, gain=2.0)
    for t, jitter in enumerate(jitters):
        prev = jitters[t - 1]
        f = random_frame(rng, H, W, scale)
        args = (f["history"], f["prev_depth"], f["motion"], prev, jitter, scale)
        (warped, warped_depth), (m_warped, m_depth) = ref.warp(*args), mesa.warp(*args)
        assert_float_close(m_warped, warped)
        assert_float_close(m_depth, warped_depth)
        for activation in ("sigmoid", "tanh"):
            w_args = (f["color"], f["depth"], warped, warped_depth, jitter, scale, conv, activation)
            assert_float_close(mesa.inpaint_weights(*w_args), ref.inpaint_weights(*w_args))
        lr_weight = ref.inpaint_weights(f["color"], f["depth"], warped, warped_depth, jitter, scale, conv, "sigmoid")
        for mode in ("bilinear", "nearest"):
            for reset in (False, True):
                b_args = (f["color"], warped, lr_weight, jitter, scale, mode, reset)
                assert_float_close(mesa.inpaint_blend(*b_args), ref.inpaint_blend(*b_args))


@pytest.mark.parametrize("motion", [-40.0, -3.3, 2.7, 55.0], ids=["far-left-up", "left-up", "right-down", "far-right-down"])
def test_warp_negative_and_off_screen_motion(mesa, ref, motion):
    """Uniform motion, far enough to leave the screen: clamp-to-edge reads the border texels."""
    rng = np.random.default_rng(7)
    f = random_frame(rng, H, W, 2)
    field = np.full((H, W, 2), motion, np.float32)
    field[..., 1] *= -0.5  # different size and sign on y
    args = (f["history"], f["prev_depth"], field, (0.25, -0.25), (-0.25, 0.25), 2)
    for got, want in zip(mesa.warp(*args), ref.warp(*args)):
        assert_float_close(got, want)
    corner = {-40.0: (-1, 0), 55.0: (0, -1)}.get(motion)  # every source off-screen past one corner
    if corner is not None:
        warped, warped_depth = mesa.warp(*args)
        assert np.all(warped == f["history"][corner])
        assert np.all(warped_depth == OFFSCREEN_DEPTH)  # no history: the inpainting sees |depth - D_W| >= 1


@pytest.mark.parametrize("scale", [2, 3])
def test_avgpool_and_conv_stack_match_reference(mesa, ref, scale):
    rng = np.random.default_rng(scale)
    f = random_frame(rng, H, W, scale)
    for jitter in pattern_jitters("grid", scale):  # the sampled texel differs per sub-pixel
        for at_samples in (False, True):
            pooled = mesa.avgpool(f["history"], f["color"], jitter, scale, at_samples)
            assert pooled.shape[-1] == (9 if at_samples else 6)
            assert_float_close(pooled, ref.avgpool(f["history"], f["color"], jitter, scale, at_samples))
    # 9 -> 5 (two output layers, one partly used) -> 9 (three input layers) -> 3 with the residual
    convs = [random_conv(rng, 5, 9), random_conv(rng, 9, 5), random_conv(rng, 3, 9)]
    x = pooled
    for conv, epilogue in zip(convs, ("relu", "none", "residual_clamp")):
        residual = f["color"] if epilogue == "residual_clamp" else None
        want = ref.conv3x3(x, conv, epilogue, residual)
        assert_float_close(mesa.conv3x3(x, conv, epilogue, residual), want)
        x = want
    assert x.min() >= 0 and x.max() <= 1


@pytest.mark.parametrize("scale", [2, 3])
def test_sharpen_matches_reference(mesa, ref, scale):
    """8-bit display codes: equal, except by one code where the float value is within
    FLOAT_ATOL of a rounding boundary (the float sums may round differently there)."""
    rng = np.random.default_rng(scale)
    image = to_half(rng.random((H * scale, W * scale, 3), dtype=np.float32))
    got, want = mesa.sharpen(image, 0.15), ref.sharpen(image, 0.15)
    diff = np.abs(got.astype(int) - want.astype(int))
    codes = unsharp(image, 0.15) * 255
    near_boundary = np.abs(codes - np.floor(codes) - 0.5) <= 255 * FLOAT_ATOL
    assert diff.max() <= 1 and np.all(near_boundary[diff > 0])
