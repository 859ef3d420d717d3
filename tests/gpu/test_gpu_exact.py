"""The integer-exact paths of the GPU stage, on Mesa, against numpy bit for bit: fp16 rounding
of every store, the int8 pack of the NPU input (every finite fp16 value, every numerics
profile, ties, saturation, negatives) and the unpack of the NPU output (every int8 value)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mnss_kit.gpu import mesa as mesa_module
from mnss_kit.gpu.glsl import flatten_text
from mnss_kit.gpu.passes import quantize_uniforms
from mnss_kit.ops.int8 import quantize as quant
from mnss_kit.ops.runtimes import RUNTIMES, get_runtime

HALF_BITS_SHADER = """#version 310 es
precision highp float;
precision highp int;
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { float xs[]; };
layout(std430, binding = 1) writeonly buffer Out { uint bits[]; };
uniform int u_count;
#include "common.glsl"
void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i < u_count) {
        bits[i] = half_bits(xs[i]);
    }
}
"""


QUANTIZE_SHADER = """#version 310 es
precision highp float;
precision highp int;
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { float xs[]; };
layout(std430, binding = 1) writeonly buffer Out { int qs[]; };
uniform int u_count;
uniform float u_q_scale;
uniform float u_q_reciprocal;
uniform int u_q_use_reciprocal;
uniform int u_q_rounding;
uniform int u_q_zero_point;
#include "quant.glsl"
void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i < u_count) {
        qs[i] = quantize_int8(xs[i], QuantParams(u_q_scale, u_q_reciprocal, u_q_use_reciprocal != 0, u_q_rounding,
                                                 u_q_zero_point));
    }
}
"""


def run_buffer_shader(mesa, source: str, xs: np.ndarray, uniforms: dict) -> np.ndarray:
    """Run a test shader mapping float buffer ``xs`` to a 32-bit buffer; returns its raw uint32 words."""
    prog = mesa.compile(flatten_text(source))
    out, inputs = mesa.ctx.buffer(reserve=4 * len(xs)), mesa.ctx.buffer(np.ascontiguousarray(xs, np.float32).tobytes())
    inputs.bind_to_storage_buffer(0)
    out.bind_to_storage_buffer(1)
    for key, value in {"u_count": len(xs), **uniforms}.items():
        prog[key].value = value
    prog.run(-(-len(xs) // 64))
    mesa.ctx.finish()
    return np.frombuffer(out.read(), np.uint32).copy()


def all_finite_halves() -> np.ndarray:
    """Every finite float16 value (both zeros), as float32."""
    h = np.arange(1 << 16, dtype=np.uint32).astype(np.uint16).view(np.float16)
    return h[np.isfinite(h)].astype(np.float32)


def float32_probes() -> np.ndarray:
    """float32 values around every fp16 rounding boundary (exact ties and one float32 step either
    side), the overflow threshold, subnormal halves, and random bit patterns."""
    halves = np.sort(np.unique(all_finite_halves()))
    mids = ((halves[:-1].astype(np.float64) + halves[1:]) / 2).astype(np.float32)  # exact in float32
    around = np.concatenate([mids, np.nextafter(mids, np.inf), np.nextafter(mids, -np.inf)])
    edges = np.array([65504, 65519.99, 65520, 65536, 1e30, 2.0**-25, 2.0**-26, 3 * 2.0**-26, 2.0**-24, 1e-40], np.float32)
    bits = np.random.default_rng(0).integers(0, 1 << 32, 20000, dtype=np.uint64).astype(np.uint32).view(np.float32)
    values = np.concatenate([halves, around, edges, -edges, bits])
    return values[np.isfinite(values)]


def test_fp16_store_rounding_matches_numpy(mesa):
    """round_to_half (every fp16 store) is numpy's float32 -> float16, ties to even, overflow to inf."""
    xs = float32_probes()
    got = run_buffer_shader(mesa, HALF_BITS_SHADER, xs, {})
    with np.errstate(over="ignore"):
        want = xs.astype(np.float16).view(np.uint16).astype(np.uint32)
    bad = np.flatnonzero(got != want)
    assert bad.size == 0, f"{bad.size} mismatches, e.g. {xs[bad[:5]]} -> {got[bad[:5]]} want {want[bad[:5]]}"


# (scale, zero point): power-of-two scales make exact ties x / scale = k + 0.5 frequent; 1/255
# and 0.0123 have near-ties where the float32 division's own rounding decides; 3.0 and 1e-4
# squeeze or saturate most values.
QPARAMS = [(1 / 255, -128), (2.0**-7, 0), (2.0**-9, 3), (0.0123, -20), (3.0, 0), (1e-4, 127)]
HALF_UP = dataclasses.replace(RUNTIMES["tflite-ref"], name="half_up_test", quantize_rounding="half_up")
PROFILES = [*RUNTIMES, HALF_UP]


def quantized_ties(x: np.ndarray, scale: float, profile) -> int:
    """How many values of ``x`` land exactly on k + 0.5 after the profile's float32 scaling."""
    p = get_runtime(profile)
    s = np.float32(scale)
    scaled = x * (np.float32(1) / s) if p.quantize_reciprocal else x / s
    return int(np.count_nonzero(np.abs(scaled - np.floor(scaled) - 0.5) == 0))


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: getattr(p, "name", p))
@pytest.mark.parametrize("q_scale, zero_point", QPARAMS)
def test_pack_every_half_matches_quantize(mesa, ref, profile, q_scale, zero_point):
    """insert_pack over every finite fp16 value (I_R) plus random I_AA: bytes equal to
    ops.int8.quantize.quantize of the inserted image, NHWC."""
    values = all_finite_halves()
    scale, w = 2, 256
    hr_h = -(-len(values) // (w * 3))
    hr_h += hr_h % 2
    image = np.zeros(hr_h * w * 3, np.float32)
    image[: len(values)] = np.random.default_rng(1).permutation(values)
    image = image.reshape(hr_h, w, 3)
    aa = np.random.default_rng(2).permutation(values)[: (hr_h // 2) * (w // 2) * 3].reshape(hr_h // 2, w // 2, 3)
    jitter = (0.25, -0.25)  # sub-pixel (1, 0)
    got = mesa.insert_pack(image, aa, jitter, scale, q_scale, zero_point, profile)
    want = ref.insert_pack(image, aa, jitter, scale, q_scale, zero_point, profile)
    assert got.dtype == np.int8 and got.shape == (1, hr_h, w, 3)
    bad = np.argwhere(got != want)
    assert bad.size == 0, f"{len(bad)} bytes differ, first at {bad[0]}: got {got[tuple(bad[0])]}, want {want[tuple(bad[0])]}"
    if q_scale in (2.0**-7, 2.0**-9):  # the case must really contain ties, saturation and negatives
        assert quantized_ties(values, q_scale, profile) > 100
    assert (want == -128).any() and (want == 127).any()


def test_pack_handles_a_tensor_not_a_multiple_of_four_bytes(mesa, ref, monkeypatch):
    """270 bytes (67.5 words), dispatched as a folded 2D grid of workgroups."""
    monkeypatch.setattr(mesa_module, "MAX_GROUPS_X", 1)
    rng = np.random.default_rng(3)
    image = rng.random((6, 5 * 3, 3), dtype=np.float32) * 1.2 - 0.1  # 270 bytes
    aa = rng.random((2, 5, 3), dtype=np.float32)
    for jitter in [(-1 / 3, -1 / 3), (0.0, 1 / 3)]:
        got = mesa.insert_pack(image, aa, jitter, 3, 1 / 255, -128, "xnnpack")
        np.testing.assert_array_equal(got, ref.insert_pack(image, aa, jitter, 3, 1 / 255, -128, "xnnpack"))


@pytest.mark.parametrize("q_scale, zero_point", [(1 / 255, -128), (2.0**-8, 0), (0.0123, 5), (3.7, 127), (1e-3, -3)])
def test_unpack_every_int8_value_is_exact(mesa, ref, q_scale, zero_point):
    """history (fp16) and display (8-bit) equal the reference bit for bit for all 256 codes."""
    codes = np.arange(-128, 128, dtype=np.int8)
    npu_output = np.random.default_rng(4).permutation(np.tile(codes, 3)[: 10 * 23 * 3]).reshape(1, 10, 23, 3)
    history, display = mesa.unpack_history(npu_output, q_scale, zero_point)
    want_history, want_display = ref.unpack_history(npu_output, q_scale, zero_point)
    np.testing.assert_array_equal(history.view(np.uint32), want_history.view(np.uint32))
    np.testing.assert_array_equal(display, want_display)
    assert set(np.unique(npu_output)) == set(codes)


def near_ties(q_scale: float) -> np.ndarray:
    """float32 x around (k + 1/2) * scale for every int8 k (and beyond the range), 4 float32 steps
    either side: where the float32 rounding of x / scale decides the integer."""
    centres = ((np.arange(-140, 140) + 0.5) * np.float64(np.float32(q_scale))).astype(np.float32)
    xs = [centres]
    up, down = centres, centres
    for _ in range(4):
        up, down = np.nextafter(up, np.inf), np.nextafter(down, -np.inf)
        xs += [up, down]
    return np.concatenate(xs)


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: getattr(p, "name", p))
def test_quantize_float32_near_ties(mesa, profile):
    """quant.glsl on float32 inputs (24-bit significands), where the float32 rounding of the
    division or product, not only the final tie rule, decides the result."""
    p = get_runtime(profile)
    for q_scale, zero_point in [(1 / 255, -128), (0.0123, 7), (0.3, 0), (1 / 3, -1), (2.0**-7, 0)]:
        xs = near_ties(q_scale)
        got = run_buffer_shader(mesa, QUANTIZE_SHADER, xs, quantize_uniforms(q_scale, zero_point, p)).view(np.int32)
        want = quant.quantize(xs, q_scale, zero_point, "int8", p).astype(np.int32)
        bad = np.flatnonzero(got != want)
        assert bad.size == 0, f"scale {q_scale}: {bad.size} differ, e.g. x={xs[bad[0]]!r} got {got[bad[0]]} want {want[bad[0]]}"
