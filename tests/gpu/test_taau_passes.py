"""The ntaau family's GPU passes on Mesa (EGL) against their numpy reference (``ops.taau`` through
``ReferencePasses``): the reprojection with negative and off-screen motion and a reset, the
steered accumulation for every jitter pattern at scales 2 and 3.  Both go through exp and tanh,
so they are held to a tolerance (one fp16 step, one display code), not bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from gpu_helpers import assert_float_close, pattern_jitters, random_frame

from mnss_kit.gpu.reference import to_half
from mnss_kit.model.taau import TAAUParams
from mnss_kit.ops.jitter import PATTERNS

H, W = 5, 7  # LR size: odd, so edge clamping and partial workgroups are exercised
TOLERANCE = 2e-3  # about two fp16 steps at 1.0: exp and tanh differ between drivers by a few ULP
PARAMS = TAAUParams()


def _history(rng, scale):
    colour = rng.random((H * scale, W * scale, 3), dtype=np.float32)
    weight = rng.uniform(0, PARAMS.max_weight, (H * scale, W * scale, 1)).astype(np.float32)
    return to_half(np.concatenate([colour, weight], axis=-1))


@pytest.mark.parametrize("scale", [2, 3])
@pytest.mark.parametrize("motion_scale", [0.6, 4.0, 60.0], ids=["sub-pixel", "pixels", "off-screen"])
def test_reprojection_matches_reference(mesa, ref, scale, motion_scale):
    rng = np.random.default_rng(scale)
    history = _history(rng, scale)
    motion = random_frame(rng, H, W, scale, motion_scale)["motion"]
    for reset in (False, True):
        args = (history, motion, scale, reset, PARAMS.blur_penalty)
        got, want = mesa.taau_reproject(*args), ref.taau_reproject(*args)
        assert_float_close(got, want, TOLERANCE)
        if reset:
            assert np.all(got[..., 3] == 0.0)


@pytest.mark.parametrize("scale", [2, 3])
@pytest.mark.parametrize("profile", ["tflite-ref", "ort-cpu"])
def test_pack_matches_reference_within_one_step(mesa, ref, scale, profile):
    rng = np.random.default_rng(11 * scale)
    f = random_frame(rng, H, W, scale)
    reprojected = ref.taau_reproject(_history(rng, scale), f["motion"], scale, False, PARAMS.blur_penalty)
    args = (f["color"], reprojected, scale, PARAMS.max_weight, 1.0 / 200.0, -20, profile)
    got, want = mesa.taau_pack(*args), ref.taau_pack(*args)
    assert got.shape == want.shape == (1, H, W, 3 + 5 * scale * scale)
    diff = np.abs(got.astype(int) - want.astype(int))
    assert diff.max() <= 1 and (diff > 0).mean() < 0.01  # the weight's GLSL division is not correctly rounded


@pytest.mark.parametrize("pattern, scale", [(p, s) for p in PATTERNS for s in (2, 3)])
def test_steered_accumulation_matches_reference(mesa, ref, pattern, scale):
    rng = np.random.default_rng(7 * scale)
    f = random_frame(rng, H, W, scale)
    reprojected = ref.taau_reproject(_history(rng, scale), f["motion"], scale, False, PARAMS.blur_penalty)
    steering = rng.integers(-128, 128, (1, H * scale, W * scale, 6)).astype(np.int8)
    for jitter in pattern_jitters(pattern, scale)[:4]:
        # the floor fades over 2 HR pixels of motion: random_frame's motion puts pixels on both sides
        args = (steering, f["color"], reprojected, f["motion"], jitter, scale, 0.02, 3, 0.1, 1.5, 0.75, 2.0, PARAMS.sample_sigma,
                PARAMS.prior_weight, PARAMS.max_weight)
        (history, display), (want_history, want_display) = mesa.taau_accumulate(*args), ref.taau_accumulate(*args)
        assert_float_close(history, want_history, TOLERANCE)
        assert np.abs(display.astype(int) - want_display.astype(int)).max() <= 1


@pytest.mark.parametrize("scale", [2, 3])
def test_display_filter_matches_reference(mesa, ref, scale):
    """taau_filter_pass: the blend through the steered 3x3 filter (blur and sharpen, clamp-to-edge)
    plus the correction, on Mesa against the reference, with and without the filter's fade where
    the history was resampled; and the accumulation reads only the first six of the eight steering
    channels."""
    rng = np.random.default_rng(5 * scale)
    f = random_frame(rng, H, W, scale)
    reprojected = ref.taau_reproject(_history(rng, scale), f["motion"], scale, False, PARAMS.blur_penalty)
    steering = rng.integers(-128, 128, (1, H * scale, W * scale, 8)).astype(np.int8)
    args = (steering, f["color"], reprojected, f["motion"], (0.25, -0.25), scale, 0.02, 3, 0.1, 0.5, 0.75, 0.0, PARAMS.sample_sigma,
            PARAMS.prior_weight, PARAMS.max_weight)
    (history, display), (want_history, want_display) = mesa.taau_accumulate(*args), ref.taau_accumulate(*args)
    assert_float_close(history, want_history, TOLERANCE)
    assert np.array_equal(want_display, ref.taau_accumulate(steering[..., :6], *args[1:])[1])
    wants = []
    for falloff in (0.0, 4.0):
        filter_args = (steering, history, f["motion"], scale, 0.02, 3, 0.1, 0.2, falloff)
        filtered, want = mesa.taau_filter(*filter_args), ref.taau_filter(*filter_args)
        assert np.abs(filtered.astype(int) - want.astype(int)).max() <= 1
        wants.append(want.astype(int))
    assert np.abs(wants[0] - want_display.astype(int)).max() > 8  # the filter changed the display
    assert np.abs(wants[0] - wants[1]).max() > 8  # and its fade changed the filter
