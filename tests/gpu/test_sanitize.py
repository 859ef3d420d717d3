"""Input sanitization (``ops.sanitize``) in GLSL on Mesa against numpy, bit for bit, on NaN (quiet,
signalling, negative), +-Inf and finite values; and the ntaau passes, which read the engine's
colour and motion, on Mesa against their reference with NaN and Inf inputs: finite outputs, the
same values."""

from __future__ import annotations

import numpy as np
import pytest
from gpu_helpers import assert_float_close, random_conv, random_frame

from mnss_kit.gpu.glsl import flatten_text
from mnss_kit.gpu.reference import to_half
from mnss_kit.model.taau import TAAUParams
from mnss_kit.ops.sanitize import sanitize_colour, sanitize_depth, sanitize_motion

SANITIZE_SHADER = """#version 310 es
precision highp float;
precision highp int;
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { uint xs[]; };
layout(std430, binding = 1) writeonly buffer Out { uint ys[]; };
uniform int u_count;
uniform int u_kind;
#include "common.glsl"
void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i < u_count) {
        float x = uintBitsToFloat(xs[i]);
        float y = u_kind == 0 ? sanitize_colour(x) : (u_kind == 1 ? sanitize_depth(x) : sanitize_motion(x));
        ys[i] = floatBitsToUint(y);
    }
}
"""
KINDS = {"colour": (0, sanitize_colour), "depth": (1, sanitize_depth), "motion": (2, sanitize_motion)}
H, W = 5, 7
PARAMS = TAAUParams()
TOLERANCE = 2e-3  # as test_taau_passes: exp and tanh differ between drivers by a few ULP


def probes() -> np.ndarray:
    """NaNs (quiet, signalling, negative, payloads), +-Inf, every finite fp16, float32 values beyond
    fp16's range, zeros, subnormals and random bit patterns (as float32)."""
    nans = np.array([0x7FC00000, 0xFFC00000, 0x7F800001, 0xFF800001, 0x7FFFFFFF, 0x7FA00000], np.uint32).view(np.float32)
    special = np.array([np.inf, -np.inf, 0.0, -0.0, 65504, 65505, 1e30, -1e30, 1e-40, 1.0, 0.5], np.float32)
    halves = np.arange(1 << 16, dtype=np.uint32).astype(np.uint16).view(np.float16).astype(np.float32)
    bits = np.random.default_rng(0).integers(0, 1 << 32, 20000, dtype=np.uint64).astype(np.uint32).view(np.float32)
    return np.concatenate([nans, special, halves, bits])


@pytest.mark.parametrize("kind", list(KINDS))
def test_glsl_sanitize_matches_numpy_bit_for_bit(gl, kind):
    mesa = gl
    code, reference = KINDS[kind]
    xs = probes()
    prog = mesa.compile(flatten_text(SANITIZE_SHADER))
    out, inputs = mesa.ctx.buffer(reserve=4 * len(xs)), mesa.ctx.buffer(xs.view(np.uint32).tobytes())
    inputs.bind_to_storage_buffer(0)
    out.bind_to_storage_buffer(1)
    prog["u_count"].value = len(xs)
    prog["u_kind"].value = code
    prog.run(-(-len(xs) // 64))
    mesa.ctx.finish()
    got = np.frombuffer(out.read(), np.uint32)
    want = reference(xs).view(np.uint32)
    bad = np.flatnonzero(got != want)
    assert bad.size == 0, f"{bad.size} mismatches, e.g. {xs[bad[:5]]} -> {got[bad[:5]].view(np.float32)}"
    finite = np.isfinite(xs) & (np.abs(xs) <= 65504)
    assert np.array_equal(got[finite], xs[finite].view(np.uint32))  # identity on finite values in range


def test_sanitize_is_identity_on_finite_inputs():
    xs = probes()
    for _, reference in KINDS.values():
        finite = np.isfinite(xs) & (np.abs(xs) <= 65504)
        assert np.array_equal(reference(xs)[finite].view(np.uint32), xs[finite].view(np.uint32))
    assert np.all(np.isfinite(sanitize_colour(xs))) and np.all(np.isfinite(sanitize_motion(xs)))
    assert np.all(sanitize_depth(xs)[~np.isfinite(xs)] == 1.0)


def _bad_frame(scale):
    rng = np.random.default_rng(3 * scale)
    f = random_frame(rng, H, W, scale)
    color, motion = f["color"].copy(), f["motion"].copy()
    color[1:3, 2:4] = np.nan
    color[0, 0] = np.inf
    color[4, 6, 1] = -np.inf
    motion[2:4, 1:3] = np.nan
    motion[0, 6] = (np.inf, -np.inf)
    colour = rng.random((H * scale, W * scale, 3), dtype=np.float32)
    weight = rng.uniform(0, PARAMS.max_weight, (H * scale, W * scale, 1)).astype(np.float32)
    return color, motion, to_half(np.concatenate([colour, weight], axis=-1))


@pytest.mark.parametrize("scale", [2, 3])
def test_taau_passes_sanitize_their_inputs(gl, ref, scale):
    mesa = gl
    color, motion, history = _bad_frame(scale)
    reprojected = [p.taau_reproject(history, motion, scale, False, PARAMS.blur_penalty) for p in (mesa, ref)]
    assert np.all(np.isfinite(reprojected[0]))
    assert_float_close(*reprojected, TOLERANCE)
    args = (color, reprojected[1], scale, PARAMS.max_weight, 1.0 / 200.0, -20, "tflite-ref")
    got, want = mesa.taau_pack(*args), ref.taau_pack(*args)
    assert np.abs(got.astype(int) - want.astype(int)).max() <= 1
    steering = np.random.default_rng(scale).integers(-128, 128, (1, H * scale, W * scale, 8)).astype(np.int8)
    args = (steering, color, reprojected[1], motion, (0.25, -0.25), scale, 0.02, 3, 0.1, 1.5, 0.75, 2.0,
            PARAMS.sample_sigma, PARAMS.prior_weight, PARAMS.max_weight)
    (history_out, display), (want_history, want_display) = mesa.taau_accumulate(*args), ref.taau_accumulate(*args)
    assert np.all(np.isfinite(history_out)) and np.all(np.isfinite(want_history))
    # next to a saturated (+-65504) sample the blend cancels terms of that size: the float order of
    # the sums decides the last bits there, so those HR texels are held to finiteness only
    far = np.ones((H, W), bool)
    for y, x in np.argwhere(np.isinf(color).any(axis=-1)):
        far[max(y - 2, 0):y + 3, max(x - 2, 0):x + 3] = False
    far = np.repeat(np.repeat(far, scale, axis=0), scale, axis=1)
    assert far.sum() > far.size // 3
    assert_float_close(history_out[far], want_history[far], TOLERANCE)
    assert np.abs(display[far].astype(int) - want_display[far].astype(int)).max() <= 1
    args = (steering, want_history, motion, scale, 0.02, 3, 0.1, 0.5, 0.75)
    got, want = mesa.taau_filter(*args), ref.taau_filter(*args)
    assert np.abs(got.astype(int) - want.astype(int)).max() <= 1


@pytest.mark.parametrize("scale", [2, 3])
def test_mnss_passes_sanitize_their_inputs(gl, ref, scale):
    """warp (previous depth, motion), inpainting weights and blend, pooling and the AA net's residual
    (colour, depth) on NaN / Inf inputs: finite, and the reference's values."""
    mesa = gl
    rng = np.random.default_rng(17 * scale)
    f = random_frame(rng, H, W, scale)
    color, motion, _ = _bad_frame(scale)
    depth, prev_depth = f["depth"].copy(), f["prev_depth"].copy()
    depth[:2] = np.inf
    depth[3, 3] = np.nan
    prev_depth[:, :2] = np.inf
    prev_depth[4, 5] = np.nan
    conv = random_conv(rng, 1, 4)
    jitter, prev = (0.25, -0.25), (-0.25, 0.25)
    args = (f["history"], prev_depth, motion, prev, jitter, scale)
    (warped, warped_depth), got = ref.warp(*args), mesa.warp(*args)
    assert np.all(np.isfinite(warped)) and np.all(np.isfinite(warped_depth))
    assert_float_close(got[0], warped)
    assert_float_close(got[1], warped_depth)
    w_args = (color, depth, warped, warped_depth, jitter, scale, conv, "sigmoid")
    lr_weight = ref.inpaint_weights(*w_args)
    assert np.all(np.isfinite(lr_weight))
    assert_float_close(mesa.inpaint_weights(*w_args), lr_weight)
    for reset in (False, True):
        b_args = (color, warped, lr_weight, jitter, scale, "bilinear", reset)
        want = ref.inpaint_blend(*b_args)
        assert np.all(np.isfinite(want))
        got = mesa.inpaint_blend(*b_args)
        small = np.abs(want) < 2.0  # elsewhere blends of a +-65504 sample: finite, within 1 %
        assert_float_close(got[small], want[small])
        assert np.all(np.isfinite(got)) and np.all(np.abs(got - want)[~small] <= 0.01 * np.abs(want)[~small])
    want = ref.avgpool(f["history"], color, jitter, scale, True)
    assert np.all(np.isfinite(want))
    got = mesa.avgpool(f["history"], color, jitter, scale, True)
    assert_float_close(got[..., :6], want[..., :6])
    assert np.array_equal(got[..., 6:], want[..., 6:])  # the sanitized colour, +-65504 included
    x = to_half(rng.random((H, W, 9), dtype=np.float32))
    last = random_conv(rng, 3, 9)
    want = ref.conv3x3(x, last, "residual_clamp", color)
    assert np.all(np.isfinite(want))
    assert_float_close(mesa.conv3x3(x, last, "residual_clamp", color), want)


@pytest.mark.parametrize("demodulate", [False, True])
def test_fusesr_passes_sanitize_their_inputs(gl, ref, demodulate):
    """demodulate_pass on NaN / Inf colour and gbuffer_pack_pass on NaN / Inf HR depth: finite and
    the reference's values (the int8 pack bit for bit)."""
    mesa, scale = gl, 2
    rng = np.random.default_rng(23)
    color, _, _ = _bad_frame(scale)
    fbeta = to_half(rng.uniform(0.05, 1.0, (H, W, 3)).astype(np.float32))
    emissive = to_half(rng.uniform(0.0, 0.2, (H, W, 3)).astype(np.float32))
    got, want = mesa.demodulate(color, fbeta, emissive, demodulate), ref.demodulate(color, fbeta, emissive, demodulate)
    assert np.all(np.isfinite(want)) and np.all(np.isfinite(got))
    small = np.abs(want) < 2.0
    assert_float_close(got[small], want[small])
    depth = rng.uniform(0, 1, (H * scale, W * scale, 1)).astype(np.float32)
    depth[:4] = np.inf
    depth[5, 5] = np.nan
    depth[6, 7] = -np.inf
    args = (np.zeros((H, W, 3), np.float32), np.zeros((H, W, 1), np.float32), None, {"depth": depth}, scale, False, False,
            1.0 / 255.0, -128, "tflite-ref")
    assert np.array_equal(mesa.gbuffer_pack(*args), ref.gbuffer_pack(*args))
    far = ref.gbuffer_pack(*args[:3], {"depth": np.ones_like(depth)}, *args[4:])
    assert np.array_equal(ref.gbuffer_pack(*args)[..., 4:].reshape(-1)[:4], far[..., 4:].reshape(-1)[:4])


@pytest.mark.parametrize("scale", [2, 3])
def test_mnss_keeps_the_history_at_a_non_finite_sample(gl, ref, scale):
    """A colour texel with NaN or Inf in any channel is no sample for MNSS: its inpainting weight is
    0, the AA net's last layer writes NO_SAMPLE there and insert + pack leaves the rectified history
    at its sub-pixel; Mesa and the reference agree, and the int8 NPU input is bit for bit theirs."""
    from mnss_kit.ops import subpixel
    from mnss_kit.ops.sanitize import NO_SAMPLE, colour_not_finite

    mesa = gl
    rng = np.random.default_rng(41 * scale)
    f = random_frame(rng, H, W, scale, motion_scale=0.5)
    color, _, _ = _bad_frame(scale)
    invalid = colour_not_finite(color)[..., 0]
    assert 0 < invalid.sum() < invalid.size
    jitter, prev = (0.25, -0.25), (-0.25, 0.25)
    warped, warped_depth = ref.warp(f["history"], f["prev_depth"], f["motion"], prev, jitter, scale)
    conv = random_conv(rng, 1, 4)
    args = (color, f["depth"], warped, warped_depth, jitter, scale, conv, "sigmoid")
    lr_weight, got = ref.inpaint_weights(*args), mesa.inpaint_weights(*args)
    assert np.all(lr_weight[invalid] == 0) and np.all(got[invalid] == 0)
    assert_float_close(got, lr_weight)
    x = to_half(rng.random((H, W, 9), dtype=np.float32))
    last = random_conv(rng, 3, 9)
    aa, got = ref.conv3x3(x, last, "residual_clamp", color), mesa.conv3x3(x, last, "residual_clamp", color)
    assert np.all(aa[invalid] == NO_SAMPLE) and np.all(got[invalid] == NO_SAMPLE)
    assert np.all((aa[~invalid] >= 0) & (aa[~invalid] <= 1))
    assert_float_close(got, aa)
    rectified = to_half(rng.random((H * scale, W * scale, 3), dtype=np.float32))
    args = (rectified, aa, jitter, scale, 1.0 / 255.0, -128, "tflite-ref")
    packed = ref.insert_pack(*args)
    assert np.array_equal(mesa.insert_pack(*args), packed)
    # the tensor of inserting the history's own values at the bad samples
    kept = np.where(invalid[..., None], subpixel.extract_samples(rectified, jitter, scale), aa)
    assert np.array_equal(packed, ref.insert_pack(rectified, kept, jitter, scale, 1.0 / 255.0, -128, "tflite-ref"))
