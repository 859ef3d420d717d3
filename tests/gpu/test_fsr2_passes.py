"""The fsr2 baseline's GPU passes on Mesa (EGL) against their numpy reference (``ops.fsr2``
through ``ReferencePasses``): the reconstruction bit for bit (copies and integer atomics), the
depth clip, accumulation and RCAS within 1e-3 (sin, sqrt and divisions differ between drivers by
a few ULP; fp16 storage of the weight above 2 within one fp16 step), and a few chained frames."""

from __future__ import annotations

import numpy as np
import pytest
from gpu_helpers import assert_float_close, pattern_jitters, random_frame

from mnss_kit.gpu.reference import to_half
from mnss_kit.ops.fsr2 import FSR2Params

H, W = 5, 7  # LR size: odd, so edge clamping and partial workgroups are exercised
TOLERANCE = 1e-3
PARAMS = FSR2Params(sharpness=0.5)


def _state(rng, scale):
    history = np.concatenate([rng.random((H * scale, W * scale, 3), dtype=np.float32),
                              rng.uniform(0, PARAMS.max_weight, (H * scale, W * scale, 1)).astype(np.float32)], axis=-1)
    locks = np.concatenate([rng.choice([0.0, 0.5, 1.0], (H * scale, W * scale, 1)), rng.random((H * scale, W * scale, 1))], axis=-1)
    return to_half(history), to_half(locks.astype(np.float32))


def _depth_with_a_moving_box(rng):
    """Depth with a near box over a far slope, so the dilation and the depth clip both act."""
    depth = (0.5 + 0.02 * np.arange(W)[None, :, None] + 0.01 * rng.random((H, W, 1))).astype(np.float32)
    depth[1:4, 2:5] = 0.1
    return depth


@pytest.mark.parametrize("motion_scale", [0.6, 4.0, 60.0], ids=["sub-pixel", "pixels", "off-screen"])
def test_reconstruction_is_exact(mesa, ref, motion_scale):
    rng = np.random.default_rng(3)
    f = random_frame(rng, H, W, 2, motion_scale)
    for depth in (f["depth"], _depth_with_a_moving_box(rng)):
        (dilated, words), (want_dilated, want_words) = mesa.fsr2_reconstruct(depth, f["motion"], PARAMS), ref.fsr2_reconstruct(depth, f["motion"], PARAMS)
        np.testing.assert_array_equal(dilated, want_dilated)
        np.testing.assert_array_equal(words, want_words)
    assert (want_words == 0).any() if motion_scale == 60.0 else (want_words > 0).any()  # far motion lands off-screen


@pytest.mark.parametrize("motion_scale", [0.6, 4.0, 60.0], ids=["sub-pixel", "pixels", "off-screen"])
def test_depth_clip_matches_reference(mesa, ref, motion_scale):
    rng = np.random.default_rng(5)
    f = random_frame(rng, H, W, 2, motion_scale)
    dilated, words = ref.fsr2_reconstruct(_depth_with_a_moving_box(rng), f["motion"], PARAMS)
    got, want = mesa.fsr2_depth_clip(dilated, f["color"], words, PARAMS), ref.fsr2_depth_clip(dilated, f["color"], words, PARAMS)
    assert_float_close(got, want, TOLERANCE)
    assert want[..., 1].any()  # random colour has thin features


@pytest.mark.parametrize("pattern, scale", [("grid", 2), ("halton", 2), ("grid", 3)])
def test_accumulation_matches_reference(mesa, ref, pattern, scale):
    rng = np.random.default_rng(7 * scale)
    f = random_frame(rng, H, W, scale)
    history, locks = _state(rng, scale)
    dilated, words = ref.fsr2_reconstruct(_depth_with_a_moving_box(rng), f["motion"], PARAMS)
    analysis = ref.fsr2_depth_clip(dilated, f["color"], words, PARAMS)
    reactive = rng.random((H, W, 1), dtype=np.float32)
    for k, jitter in enumerate(pattern_jitters(pattern, scale)[:4]):
        args = (f["color"], dilated, analysis, history, locks, reactive if k == 1 else None, words, jitter, scale, k == 2, PARAMS)
        (got_history, got_locks, cleared), (want_history, want_locks, _) = mesa.fsr2_accumulate(*args), ref.fsr2_accumulate(*args)
        assert_float_close(got_history, want_history, TOLERANCE)
        assert_float_close(got_locks, want_locks, TOLERANCE)
        assert not cleared.any()


@pytest.mark.parametrize("sharpness", [0.0, 0.5, 1.0])
def test_rcas_matches_reference(mesa, ref, sharpness):
    image = to_half(np.random.default_rng(9).random((11, 13, 3), dtype=np.float32))
    got, want = mesa.fsr2_rcas(image, sharpness), ref.fsr2_rcas(image, sharpness)
    assert_float_close(got, want, TOLERANCE)
    assert (sharpness == 0.0) == np.array_equal(want, image)


def test_chained_frames_match_reference(mesa, ref):
    """Five frames of a box moving over a slope, each pass's output fed to the next and the state
    kept on each side: the outputs stay within 1e-3 of the reference."""
    rng = np.random.default_rng(11)
    scale = 2
    colour = to_half(rng.random((H, W, 3), dtype=np.float32))
    states = {}
    for t, jitter in enumerate(pattern_jitters("grid", scale)[:4].tolist() + [[0.25, 0.25]]):
        depth = np.roll(_depth_with_a_moving_box(rng), t, axis=1)
        motion = np.zeros((H, W, 2), np.float32)
        motion[..., 0] = -1.0 * (depth[..., 0] < 0.2)
        colour = np.roll(colour, 1, axis=1)
        outputs = {}
        for name, passes in (("mesa", mesa), ("ref", ref)):
            history, locks = states.get(name, (np.zeros((H * scale, W * scale, 4), np.float32),) * 2)
            dilated, words = passes.fsr2_reconstruct(depth, motion, PARAMS)
            analysis = passes.fsr2_depth_clip(dilated, colour, words, PARAMS)
            history, locks, _ = passes.fsr2_accumulate(colour, dilated, analysis, history, locks, None, words, jitter, scale,
                                                       t == 0, PARAMS)
            states[name] = (history, locks)
            outputs[name] = passes.fsr2_rcas(history, PARAMS.sharpness)
        assert_float_close(outputs["mesa"], outputs["ref"], TOLERANCE)
        assert_float_close(states["mesa"][0], states["ref"][0], TOLERANCE)


def test_bad_input_texels_are_sanitized_alike(mesa, ref):
    """NaN colour, Inf depth and NaN motion texels: the passes read them through common.glsl's
    sanitize and the reference through ops.sanitize, so both stay finite and agree."""
    rng = np.random.default_rng(13)
    scale = 2
    f = random_frame(rng, H, W, scale)
    colour, depth, motion = f["color"].copy(), _depth_with_a_moving_box(rng), f["motion"].copy()
    colour[1, 1] = np.nan
    colour[3, 5, 0] = np.inf
    depth[0, 0] = np.inf
    motion[2, 3] = np.nan
    history, locks = _state(rng, scale)
    results = {}
    for name, passes in (("mesa", mesa), ("ref", ref)):
        dilated, words = passes.fsr2_reconstruct(depth, motion, PARAMS)
        analysis = passes.fsr2_depth_clip(dilated, colour, words, PARAMS)
        results[name] = passes.fsr2_accumulate(colour, dilated, analysis, history, locks, None, words,
                                               [0.25, -0.25], scale, False, PARAMS)[:2]
    for got, want in zip(results["mesa"], results["ref"]):
        assert np.isfinite(want).all()
        assert_float_close(got, want, TOLERANCE)
