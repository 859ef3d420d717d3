"""The ntaau_lr family's GPU passes on Mesa (EGL) against their numpy reference (``ops.taau_lr``
through ``ReferencePasses``): the evidence (with a reset), the LR feature pack padded to an even
size, the accumulation steered from LR (bilinear upsample, trust gating, fallback) and the display
filter, at even and odd LR sizes.  exp, tanh and a division: held to the ntaau passes' tolerances."""

from __future__ import annotations

import numpy as np
import pytest
from gpu_helpers import assert_float_close, pattern_jitters, random_frame

from mnss_kit.gpu.reference import to_half
from mnss_kit.model.taau import TAAUParams

SIZES = [(5, 7), (6, 8)]  # LR (h, w): odd (padded to even, partial workgroups) and even
TOLERANCE = 2e-3  # as tests/gpu/test_taau_passes.py: a few fp16 steps, exp and tanh differ by a few ULP
PARAMS = TAAUParams()
TRUST = (0.1, 1.0)  # trust_depth, trust_spread_px


def _history(rng, h, w, scale):
    colour = rng.random((h * scale, w * scale, 3), dtype=np.float32)
    weight = rng.uniform(0, PARAMS.max_weight, (h * scale, w * scale, 1)).astype(np.float32)
    return to_half(np.concatenate([colour, weight], axis=-1))


def _frame(ref, seed, h, w, scale):
    """A random frame (depth near the previous one, so trust spans [0, 1]), its reprojected history and evidence."""
    rng = np.random.default_rng(seed)
    f = random_frame(rng, h, w, scale)
    f["motion"][:, : w // 2] = np.float32(0.3) + f["motion"][:, : w // 2] * np.float32(0.02)  # still enough to trust
    f["depth"] = (0.3 + 0.1 * f["depth"]).astype(np.float32)
    f["prev_depth"] = f["depth"] * rng.uniform(0.99, 1.01, f["depth"].shape).astype(np.float32)
    f["prev_depth"][: h // 2] *= np.float32(0.5)  # the upper half was nearer: disoccluded now
    f["reprojected"] = ref.taau_reproject(_history(rng, h, w, scale), f["motion"], scale, False, PARAMS.blur_penalty)
    f["evidence"] = ref.taau_lr_evidence(f["depth"], f["prev_depth"], f["motion"], False, *TRUST)
    return rng, f


@pytest.mark.parametrize("size", SIZES, ids=["odd", "even"])
def test_evidence_matches_reference(mesa, ref, size):
    _, f = _frame(ref, 1, *size, 2)
    for reset in (False, True):
        args = (f["depth"], f["prev_depth"], f["motion"], reset, *TRUST)
        got, want = mesa.taau_lr_evidence(*args), ref.taau_lr_evidence(*args)
        assert_float_close(got, want, 1e-5)
    trust = f["evidence"][..., 2]
    assert (trust == 0).any() and (trust > 0.5).any()


@pytest.mark.parametrize("size", SIZES, ids=["odd", "even"])
@pytest.mark.parametrize("scale", [2, 3])
@pytest.mark.parametrize("profile", ["tflite-ref", "ort-cpu"])
def test_pack_matches_reference_within_one_step(mesa, ref, size, scale, profile):
    _, f = _frame(ref, 11 * scale, *size, scale)
    for reset in (False, True):  # a reset: the history is zero, whatever the reprojection holds
        args = (f["color"], f["reprojected"], f["evidence"], scale, reset, PARAMS.max_weight, 1.0 / 100.0, -20, profile)
        got, want = mesa.taau_lr_pack(*args), ref.taau_lr_pack(*args)
        assert got.shape == want.shape == (1, size[0] + size[0] % 2, size[1] + size[1] % 2, 8)
        diff = np.abs(got.astype(int) - want.astype(int))
        assert diff.max() <= 1 and (diff > 0).mean() < 0.01  # block means and a division: not correctly rounded


@pytest.mark.parametrize("size", SIZES, ids=["odd", "even"])
@pytest.mark.parametrize("scale", [2, 3])
def test_steered_accumulation_matches_reference(mesa, ref, size, scale):
    rng, f = _frame(ref, 7 * scale, *size, scale)
    h, w = size
    steering = rng.integers(-128, 128, (1, h + h % 2, w + w % 2, 6)).astype(np.int8)
    for jitter in pattern_jitters("grid", scale)[:2]:
        args = (steering, f["color"], f["reprojected"], f["evidence"], jitter, scale, 0.03, 3, 1.5, PARAMS.sample_sigma,
                PARAMS.prior_weight, PARAMS.max_weight)
        (history, display), (want_history, want_display) = mesa.taau_lr_accumulate(*args), ref.taau_lr_accumulate(*args)
        assert_float_close(history, want_history, TOLERANCE)
        assert np.abs(display.astype(int) - want_display.astype(int)).max() <= 1


@pytest.mark.parametrize("size", SIZES, ids=["odd", "even"])
def test_display_filter_matches_reference(mesa, ref, size):
    rng, f = _frame(ref, 5, *size, 2)
    h, w = size
    steering = rng.integers(-128, 128, (1, h + h % 2, w + w % 2, 6)).astype(np.int8)
    history = _history(rng, h, w, 2)
    args = (steering, history, 2, 0.03, 3, 0.25)
    got, want = mesa.taau_lr_filter(*args), ref.taau_lr_filter(*args)
    assert np.abs(got.astype(int) - want.astype(int)).max() <= 1
    plain = ref.taau_lr_filter(steering, history, 2, 0.03, 3, 0.0)
    assert np.abs(want.astype(int) - plain.astype(int)).max() > 8  # the filter changed the display


def test_passes_sanitize_their_inputs(mesa, ref):
    """NaN and +-Inf in this frame's colour, depth and motion and in the stored previous depth: the
    evidence and the pack on Mesa as their reference, every value finite (``ops.sanitize``)."""
    h, w = SIZES[0]
    _, f = _frame(ref, 3, h, w, 2)
    for key, channel in (("color", 0), ("depth", 0), ("prev_depth", 0), ("motion", 1)):
        f[key] = f[key].copy()
        f[key][1, 2, channel], f[key][3, 4, channel], f[key][0, 0, channel] = np.nan, np.inf, -np.inf
    args = (f["depth"], f["prev_depth"], f["motion"], False, *TRUST)
    got, want = mesa.taau_lr_evidence(*args), ref.taau_lr_evidence(*args)
    assert np.isfinite(want).all()
    assert_float_close(got, want, 1e-5)
    pack = (f["color"], f["reprojected"], want, 2, False, PARAMS.max_weight, 1.0 / 100.0, -20, "tflite-ref")
    assert np.abs(mesa.taau_lr_pack(*pack).astype(int) - ref.taau_lr_pack(*pack).astype(int)).max() <= 1


@pytest.mark.parametrize("size", SIZES, ids=["odd", "even"])
@pytest.mark.parametrize("scale", [2, 3])
def test_steered_accumulation_with_a_history_floor_matches_reference(mesa, ref, size, scale):
    """``u_history_gain_min`` 1, ``u_still_motion_px`` 1: the history gain, after the trust gate, at
    least the floor that fades with the HR motion (``ops.taau.history_floor``), read from ``motion``."""
    rng, f = _frame(ref, 13 * scale, *size, scale)
    h, w = size
    steering = rng.integers(-128, 128, (1, h + h % 2, w + w % 2, 6)).astype(np.int8)
    f["motion"][:, w // 2:] *= np.float32(0.1)  # part of the frame moves under a HR pixel: the floor holds there
    jitter = pattern_jitters("grid", scale)[0]
    args = (steering, f["color"], f["reprojected"], f["evidence"], jitter, scale, 0.03, 3, 1.5, PARAMS.sample_sigma,
            PARAMS.prior_weight, PARAMS.max_weight)
    floor = dict(motion=f["motion"], history_gain_min=1.0, still_motion_px=1.0)
    (history, display), (want_history, want_display) = mesa.taau_lr_accumulate(*args, **floor), ref.taau_lr_accumulate(*args, **floor)
    assert_float_close(history, want_history, TOLERANCE)
    assert np.abs(display.astype(int) - want_display.astype(int)).max() <= 1
    plain, _ = ref.taau_lr_accumulate(*args)
    assert np.abs(want_history.astype(np.float32) - plain.astype(np.float32)).max() > 0.01  # the floor changed the blend


# -- the detail branch (model.detail): its inputs in the pack, its patch on the display ----------
DETAIL_BOUND = 0.1


def _detail_steering(rng, h, w):
    """Random int8 NPU output with a detail branch's 4 channels after the 6 steering ones, and its first 6 alone."""
    steering = rng.integers(-128, 128, (1, h + h % 2, w + w % 2, 10)).astype(np.int8)
    return steering, np.ascontiguousarray(steering[..., :6])


@pytest.mark.parametrize("size", SIZES, ids=["odd", "even"])
@pytest.mark.parametrize("scale", [2, 3])
@pytest.mark.parametrize("scale_input", [False, True], ids=["features", "scale_input"])
def test_pack_with_the_detail_inputs_matches_reference(mesa, ref, size, scale, scale_input):
    """``u_detail`` 1: the clamped history's luma at the s x s HR texels of each LR texel follow the
    features (and the scale input), within one step of the reference as the features are."""
    _, f = _frame(ref, 17 * scale, *size, scale)
    value = 1.0 / scale if scale_input else 0.0
    for reset in (False, True):
        args = (f["color"], f["reprojected"], f["evidence"], scale, reset, PARAMS.max_weight, 1.0 / 100.0, -20, "tflite-ref")
        got, want = mesa.taau_lr_pack(*args, value, True), ref.taau_lr_pack(*args, value, True)
        channels = 8 + int(scale_input) + scale * scale
        assert got.shape == want.shape == (1, size[0] + size[0] % 2, size[1] + size[1] % 2, channels)
        diff = np.abs(got.astype(int) - want.astype(int))
        assert diff.max() <= 1 and (diff > 0).mean() < 0.01
        plain = ref.taau_lr_pack(*args, value)
        assert np.array_equal(want[..., :plain.shape[-1]], plain)  # the detail inputs come last
        luma = want[..., plain.shape[-1]:]
        if reset:  # a zero history clamps to the box's low luma: one value per block
            assert (luma == luma[..., :1]).all()
        else:
            assert np.unique(luma).size > 10


@pytest.mark.parametrize("size", SIZES, ids=["odd", "even"])
@pytest.mark.parametrize("scale", [2, 3])
def test_steered_accumulation_with_a_detail_branch_matches_reference(mesa, ref, size, scale):
    """A 10-channel NPU output: the blend reads its 6 steering channels (the history never holds the
    patch); the display gets the patch when ``u_detail_bound`` > 0 (a model without a display filter)."""
    rng, f = _frame(ref, 19 * scale, *size, scale)
    steering, plain = _detail_steering(rng, *size)
    rest = (f["color"], f["reprojected"], f["evidence"], pattern_jitters("grid", scale)[0], scale, 0.03, 3, 1.5,
            PARAMS.sample_sigma, PARAMS.prior_weight, PARAMS.max_weight)
    plain_history, plain_display = ref.taau_lr_accumulate(plain, *rest)
    for bound in (0.0, DETAIL_BOUND):  # 0: the filter pass draws the patch
        history, display = mesa.taau_lr_accumulate(steering, *rest, detail_bound=bound)
        want_history, want_display = ref.taau_lr_accumulate(steering, *rest, detail_bound=bound)
        assert_float_close(history, want_history, TOLERANCE)
        assert np.abs(display.astype(int) - want_display.astype(int)).max() <= 1
        assert np.array_equal(want_history, plain_history)
        drawn = np.abs(want_display.astype(int) - plain_display.astype(int)).max()
        assert drawn > 8 if bound else drawn == 0


@pytest.mark.parametrize("size", SIZES, ids=["odd", "even"])
@pytest.mark.parametrize("scale", [2, 3])
def test_display_filter_with_a_detail_patch_matches_reference(mesa, ref, size, scale):
    rng, _ = _frame(ref, 23 * scale, *size, scale)
    steering, plain = _detail_steering(rng, *size)
    history = _history(rng, *size, scale)
    got = mesa.taau_lr_filter(steering, history, scale, 0.03, 3, 0.25, detail_bound=DETAIL_BOUND)
    want = ref.taau_lr_filter(steering, history, scale, 0.03, 3, 0.25, detail_bound=DETAIL_BOUND)
    assert np.abs(got.astype(int) - want.astype(int)).max() <= 1
    without = ref.taau_lr_filter(plain, history, scale, 0.03, 3, 0.25)
    assert np.array_equal(ref.taau_lr_filter(steering, history, scale, 0.03, 3, 0.25), without)  # not drawn: the 6 alone
    assert np.abs(want.astype(int) - without.astype(int)).max() > 8
