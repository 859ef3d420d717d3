"""Per-runtime integer formulas of the int8 ops beyond convolution (reference definitions).

``mnss_kit.ops.quant`` defines requantization, the ADD methods, QUANTIZE and the tables once;
this module defines every other formula a runtime kernel uses for an op, so that a runtime
(``mnss_kit.ops.runtimes.RUNTIMES``) is plain data: one formula name per op
(``runtimes.FORMULAS``).  Each formula states what the runtime does, as found in LiteRT's,
XNNPACK's and ONNX Runtime's sources and checked bit for bit against ai-edge-litert 2.3.0 and
onnxruntime 1.31 on x86-64 (tests/emulate).

Two things a reader would not guess:

* LiteRT's optimized builtin kernels (``tflite-builtin``) on x86 are its ARM NEON code compiled
  through an SSE emulation of the NEON intrinsics.  Vector loops process 16 (ADD, int8
  QUANTIZE) or 8 (float QUANTIZE, DEQUANTIZE) values at a time with the vector rounding, and
  the leftover tail runs the scalar reference formula.  Where a value sits in the tensor
  therefore decides its rounding (:func:`vector_width`).
* ONNX Runtime on x86-64 runs a QDQ AveragePool as a float kernel (dequantize, float32 window
  sum in order, divide, quantize) and a QDQ Resize as dequantize, float32 bilinear resize,
  quantize; both are reproduced here operation by operation.

All arithmetic is in int64 or in explicitly float32 numpy arrays.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from . import quant
from .runtimes import Runtime, check_formula, get_runtime

INT8_MIN, INT8_MAX = quant.INT8_MIN, quant.INT8_MAX
QParams = tuple[float, int]  # (scale, zero_point)

# values per vector iteration of the formulas whose rounding depends on the position in the tensor
VECTOR_WIDTHS = {("ADD", "tflite_neon16"): 16, ("QUANTIZE", "tflite_neon8"): 8, ("DEQUANTIZE", "tflite_neon8"): 8,
                 ("REQUANTIZE", "tflite_neon16"): 16}


def vector_width(op: str, formula: str) -> int:
    """Values per vector iteration if the formula rounds the tail of a tensor differently, else 0."""
    return VECTOR_WIDTHS.get((op, formula), 0)


def _clamp_int8(x: np.ndarray, clamp: tuple[int, int] | None) -> np.ndarray:
    lo, hi = clamp if clamp is not None else (INT8_MIN, INT8_MAX)
    return np.clip(x, lo, hi).astype(np.int8)


def _by_position(width: int, body: Callable, tail: Callable, *arrays: np.ndarray) -> np.ndarray:
    """A vector kernel over flattened ``arrays``: full blocks of ``width`` values through ``body``,
    the rest through ``tail``; both map flat arrays to flat results.  Returns the input shape."""
    flat = [np.asarray(a).reshape(-1) for a in arrays]
    split = flat[0].size // width * width
    out = np.concatenate([body(*(f[:split] for f in flat)), tail(*(f[split:] for f in flat))])
    return out.reshape(np.shape(arrays[0]))


# ---------------------------------------------------------------------------
# ADD


def add(a: np.ndarray, a_q: QParams, b: np.ndarray, b_q: QParams, out_q: QParams, formula: str,
        clamp: tuple[int, int] | None = None) -> np.ndarray:
    """Quantized ADD of two int8 tensors of one shape -> int8.

    An ADD method of ``quant.add``, or ``tflite_neon16``: LiteRT's optimized kernel; the
    flattened tensor is cut into blocks of 16, full blocks take the vector formula
    (``q31_single_round_inputs``: the inputs rescaled with one rounding; NEON's truncating
    pre-shift loses no bits while the smaller input scale is at least 2^-20 of the larger) and
    the tail the reference one (``q31_double_round``).
    """
    check_formula("ADD", formula)
    if formula != "tflite_neon16":
        return quant.add(a, a_q, b, b_q, out_q, formula, clamp=clamp)
    a, b = np.broadcast_arrays(np.asarray(a), np.asarray(b))

    def by(method):
        return lambda x, y: quant.add(x, a_q, y, b_q, out_q, method, clamp=clamp)

    return _by_position(vector_width("ADD", formula), by("q31_single_round_inputs"), by("q31_double_round"), a, b)


# ---------------------------------------------------------------------------
# MUL


def mul(a: np.ndarray, a_q: QParams, b: np.ndarray, b_q: QParams, out_q: QParams, formula: str,
        clamp: tuple[int, int] | None = None) -> np.ndarray:
    """Quantized MUL of two int8 tensors of one shape -> int8.

    Every runtime forms ``p = (a - z_a) * (b - z_b)`` exactly and the real multiplier
    ``float32(float32(s_a * s_b) / s_o)`` in float32.  ``tflite`` (reference and optimized
    alike): a Q31 multiplier of it applied to ``p`` with ``MultiplyByQuantizedMultiplier``
    (double rounding), plus ``z_o``.  ``xnnpack``: ``float32(p) * m`` rounded half to even, plus
    ``z_o``.  ``onnxruntime`` (MLAS QLinearMul): ``float32(float32(p) * m) + float32(z_o)`` rounded
    half to even (the zero point joins before the rounding).
    """
    check_formula("MUL", formula)
    (sa, za), (sb, zb), (so, zo) = a_q, b_q, out_q
    real = np.float32(np.float32(np.float32(sa) * np.float32(sb)) / np.float32(so))
    product = (np.asarray(a, dtype=np.int64) - za) * (np.asarray(b, dtype=np.int64) - zb)  # |p| <= 65025
    if formula == "tflite":
        m, shift = quant.quantize_multiplier(float(real))
        out = quant.multiply_by_quantized_multiplier(product, m, shift, "away_from_zero") + zo
    else:
        scaled = (product.astype(np.float32) * real).astype(np.float32)
        if formula == "xnnpack":
            out = quant.round_float(scaled, "half_even") + zo
        else:
            out = np.rint((scaled + np.float32(zo)).astype(np.float32))
    return _clamp_int8(out, clamp)


# ---------------------------------------------------------------------------
# LOGISTIC, TANH: every runtime builds a 256-entry table in float32


def logistic(x: np.ndarray, x_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """int8 LOGISTIC through ``quant.lookup_table`` of ``quant.sigmoid_f32``; output params (1/256, -128)."""
    with np.errstate(over="ignore"):  # exp overflow gives 1/inf = 0, the right limit
        table = quant.lookup_table(quant.sigmoid_f32, x_q, quant.LOGISTIC_OUTPUT, runtime)
    return quant.apply_table(x, table)


def tanh(x: np.ndarray, x_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """int8 TANH through ``quant.lookup_table`` of ``quant.tanh_f32``; output params (1/128, 0).

    ONNX Runtime keeps a QDQ Tanh as float (dequantize, ``tanh``, quantize), which gives the
    table's values wherever its ``tanh`` and numpy's agree to the last bit.
    """
    return quant.apply_table(x, quant.lookup_table(quant.tanh_f32, x_q, quant.TANH_OUTPUT, runtime))


# ---------------------------------------------------------------------------
# AVERAGE_POOL_2D


def average_pool_divide(total: np.ndarray, count: np.ndarray, formula: str) -> np.ndarray:
    """Window sum of raw int8 values / number of valid inputs (int64 arrays, broadcastable) -> int64.

    ``tflite`` (every LiteRT runtime; XNNPACK does not take int8 AVERAGE_POOL_2D):
    ``quant.average_pool_round``, ties away from zero.  The ``onnxruntime`` formula does not
    start from the integer sum: see :func:`average_pool_float`.
    """
    check_formula("AVERAGE_POOL_2D", formula)
    if formula != "tflite":
        raise ValueError(f"AVERAGE_POOL_2D formula {formula!r} needs the float window sums (average_pool_float)")
    return quant.average_pool_round(total, np.asarray(count, dtype=np.int64))


def average_pool_float(x: np.ndarray, q: QParams, size: int, stride: int, out_hw: tuple[int, int],
                       pad: tuple[int, int]) -> np.ndarray:
    """ONNX Runtime's QLinearAveragePool (count_include_pad 0): (N, H, W, C) int8 -> (N, Ho, Wo, C) int8.

    ``q`` is the input's and output's ``(scale, zero_point)``; ``pad`` the (top, left) padding.
    Each input is dequantized to float32, the valid inputs of a window are summed in float32 in
    row-major order, the sum divided by their number, then ``rint(mean / s + z)`` (float32).
    When the one window is the whole (unpadded) image, ONNX Runtime takes its global-pool kernel
    instead: the exact integer sum of ``x - z`` times ``float32(s / (s * float32(H * W)))``,
    rounded half to even, plus ``z``.
    """
    s, zp = np.float32(q[0]), int(q[1])
    n, h, w, c = x.shape
    if (h, w) == (size, size) and tuple(out_hw) == (1, 1):  # one window, no padding on any side
        total = np.asarray(x, np.int64).sum(axis=(1, 2), keepdims=True) - zp * h * w
        scale = np.float32(s / np.float32(s * np.float32(h * w)))
        return _clamp_int8(np.rint((total.astype(np.float32) * scale).astype(np.float32)) + zp, None)
    values = quant.dequantize(x, s, zp)
    ys = np.arange(out_hw[0]) * stride - pad[0]
    xs = np.arange(out_hw[1]) * stride - pad[1]
    total = np.zeros((n, *out_hw, c), dtype=np.float32)
    count = np.zeros(out_hw, dtype=np.int64)
    for i in range(size):
        rows = ys + i
        valid_rows = (rows >= 0) & (rows < h)
        for j in range(size):
            cols = xs + j
            valid = valid_rows[:, None] & ((cols >= 0) & (cols < w))[None, :]
            tap = values[:, np.clip(rows, 0, h - 1)][:, :, np.clip(cols, 0, w - 1)]
            total += np.where(valid[None, :, :, None], tap, np.float32(0))  # adding 0.0 leaves a float sum unchanged
            count += valid
    mean = (total / count[None, :, :, None].astype(np.float32)).astype(np.float32)
    return _clamp_int8(np.rint(((mean / s).astype(np.float32) + np.float32(zp)).astype(np.float32)), None)


# ---------------------------------------------------------------------------
# RESIZE_BILINEAR


def _tflite_source_10bit(out_size: int, in_size: int, half_pixel_centers: bool):
    """LiteRT ``ComputeInterpolationValuesInteger``: source position in 1/1024 pixel and its two taps."""
    scale_10 = ((1 << 10) * in_size + out_size // 2) // out_size
    pos = np.arange(out_size, dtype=np.int64) * scale_10
    if half_pixel_centers:
        pos = pos + scale_10 // 2 - (1 << 9)
    # C division truncates toward zero; the lower tap is then clamped at 0.
    lower = np.maximum(np.where(pos >= 0, pos // 1024, -((-pos) // 1024)), 0)
    upper_raw = pos + 1023
    upper = np.minimum(np.where(upper_raw >= 0, upper_raw // 1024, -((-upper_raw) // 1024)), in_size - 1)
    frac = pos - 1024 * lower  # weight of the upper tap, in 1/1024 (may be negative near the border)
    return lower, upper, frac


def _xnnpack_source_q11(out_size: int, in_size: int, half_pixel_centers: bool):
    """XNNPACK ``indirection_init_resize_bilinear2d_hwc_q11``: float32 source position, weight in 1/2048."""
    scale = np.float32(in_size) / np.float32(out_size)
    pos = np.arange(out_size, dtype=np.float32) * scale
    if half_pixel_centers:
        offset = np.float32(0.5) * scale - np.float32(0.5)
        pos = np.clip((pos + offset).astype(np.float32), np.float32(0), np.float32(in_size - 1))
    lower = pos.astype(np.int64)  # truncation of a non-negative value
    upper = np.minimum(lower + 1, in_size - 1)
    alpha = (pos - lower.astype(np.float32)).astype(np.float32)
    return lower, upper, np.rint(alpha * np.float32(2048)).astype(np.int64)  # lrintf: ties to even


def _resize_xnnpack(x: np.ndarray, out_hw: tuple[int, int], half_pixel_centers: bool) -> np.ndarray:
    """XNNPACK s8 ``ibilinear``: horizontal then vertical lerp in Q11, one rounding (half up) at the end."""
    y0, y1, ay = _xnnpack_source_q11(out_hw[0], x.shape[1], half_pixel_centers)
    x0, x1, ax = _xnnpack_source_q11(out_hw[1], x.shape[2], half_pixel_centers)
    v = np.asarray(x, dtype=np.int64)
    rows0, rows1 = v[:, y0], v[:, y1]
    ax = ax[None, None, :, None]
    top = (rows0[:, :, x0] << 11) + (rows0[:, :, x1] - rows0[:, :, x0]) * ax
    bottom = (rows1[:, :, x0] << 11) + (rows1[:, :, x1] - rows1[:, :, x0]) * ax
    total = (top << 11) + (bottom - top) * ay[None, :, None, None]  # value in 2^-22 units
    return ((total + (1 << 21)) >> 22).astype(np.int8)


def _resize_tflite(x: np.ndarray, out_hw: tuple[int, int], half_pixel_centers: bool) -> np.ndarray:
    """LiteRT ``ResizeBilinearInteger``: four int64 weight products in 2^-20 units, rounded half away from zero."""
    y0, y1, fy = _tflite_source_10bit(out_hw[0], x.shape[1], half_pixel_centers)
    x0, x1, fx = _tflite_source_10bit(out_hw[1], x.shape[2], half_pixel_centers)
    v = np.asarray(x, dtype=np.int64)
    wy1, wy0 = fy[:, None, None], (1024 - fy)[:, None, None]
    wx1, wx0 = fx[None, :, None], (1024 - fx)[None, :, None]
    top = v[:, y0][:, :, x0] * wx0 + v[:, y0][:, :, x1] * wx1
    bottom = v[:, y1][:, :, x0] * wx0 + v[:, y1][:, :, x1] * wx1
    total = top * wy0 + bottom * wy1
    half = 1 << 19
    return np.where(total > 0, (total + half) >> 20, -((-total + half) >> 20)).astype(np.int8)


def _onnxruntime_source(out_size: int, in_size: int):
    """ONNX Runtime ``SetupUpsampleBilinear`` (half_pixel): taps and the float32 weights of the far and near tap."""
    scale = np.float32(np.float32(out_size) / np.float32(in_size))
    pos = ((np.arange(out_size, dtype=np.float32) + np.float32(0.5)) / scale).astype(np.float32) - np.float32(0.5)
    pos = np.clip(pos.astype(np.float32), np.float32(0), np.float32(in_size - 1))
    lower = np.minimum(pos.astype(np.int64), in_size - 1)
    upper = np.minimum(lower + 1, in_size - 1)
    d_lower = np.abs(pos - lower.astype(np.float32)).astype(np.float32)  # weight of the upper tap
    d_upper = np.abs(pos - upper.astype(np.float32)).astype(np.float32)  # weight of the lower tap
    same = lower == upper
    d_lower[same] = d_upper[same] = np.float32(0.5)
    return lower, upper, d_lower, d_upper


def _resize_onnxruntime(x: np.ndarray, out_hw: tuple[int, int], q: QParams) -> np.ndarray:
    """DequantizeLinear, float32 ``Resize`` (linear, half_pixel; ``dx2*dy2*X11 + dx1*dy2*X21 +
    dx2*dy1*X12 + dx1*dy1*X22`` left to right, each weight product rounded), QuantizeLinear."""
    y1, y2, dy1, dy2 = _onnxruntime_source(out_hw[0], x.shape[1])
    x1, x2, dx1, dx2 = _onnxruntime_source(out_hw[1], x.shape[2])
    v = quant.dequantize(x, q[0], q[1])
    dx1, dx2 = dx1[None, None, :, None], dx2[None, None, :, None]
    dy1, dy2 = dy1[None, :, None, None], dy2[None, :, None, None]

    def term(wx, wy, rows, cols):
        return ((wx * wy).astype(np.float32) * v[:, rows][:, :, cols]).astype(np.float32)

    total = (term(dx2, dy2, y1, x1) + term(dx1, dy2, y1, x2)).astype(np.float32)
    total = (total + term(dx2, dy1, y2, x1)).astype(np.float32)
    total = (total + term(dx1, dy1, y2, x2)).astype(np.float32)
    return quant.quantize(total, q[0], q[1], "int8", "ort-cpu")


def resize_bilinear(x: np.ndarray, out_hw: tuple[int, int], half_pixel_centers: bool, formula: str,
                    q: QParams | None = None) -> np.ndarray:
    """int8 RESIZE_BILINEAR (align_corners False), (N, H, W, C) -> (N, Ho, Wo, C); params unchanged.

    ``tflite``: LiteRT ``ResizeBilinearInteger``.  ``xnnpack_q11``: XNNPACK's Q11 lerp.
    ``onnxruntime`` (needs ``q``, the tensors' ``(scale, zero_point)``, and half-pixel
    centres): float32 resize between dequantize and quantize (:func:`_resize_onnxruntime`).
    """
    check_formula("RESIZE_BILINEAR", formula)
    if formula == "xnnpack_q11":
        return _resize_xnnpack(x, out_hw, half_pixel_centers)
    if formula == "tflite":
        return _resize_tflite(x, out_hw, half_pixel_centers)
    if q is None or not half_pixel_centers:
        raise ValueError("the onnxruntime RESIZE_BILINEAR formula needs the quantization params and half-pixel centres")
    return _resize_onnxruntime(x, out_hw, q)


# ---------------------------------------------------------------------------
# QUANTIZE float32 -> int8, DEQUANTIZE int8 -> float32


def quantize(x: np.ndarray, out_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """QUANTIZE float32 -> int8 by the runtime's ``quantize`` formula.

    ``scalar``: ``quant.quantize`` with the runtime's rounding fields.  ``tflite_neon8``: LiteRT's
    optimized kernel; full blocks of 8 (flattened) take the vector formula (``quant.quantize``
    with the runtime's fields: multiply by the float32 reciprocal, ties to even), the tail
    divides in float64 and rounds half away from zero.
    """
    rt = get_runtime(runtime)
    scale, zp = out_q
    if rt.quantize == "scalar":
        return quant.quantize(x, scale, zp, "int8", rt)

    def body(v):
        return quant.quantize(v, scale, zp, "int8", rt)

    def tail(v):
        q = quant.round_float(v.astype(np.float64) / np.float64(np.float32(scale)), "away_from_zero") + zp
        return _clamp_int8(q, None)

    return _by_position(vector_width("QUANTIZE", rt.quantize), body, tail, np.asarray(x, dtype=np.float32))


def dequantize(x: np.ndarray, x_q: QParams, formula: str) -> np.ndarray:
    """DEQUANTIZE int8 -> float32.

    ``exact``: ``quant.dequantize``, one rounding of ``scale * (q - zp)``.  ``tflite_neon8``:
    LiteRT's optimized kernel; full blocks of 8 compute ``float32(q) * scale - float32(zp * scale)``
    (two roundings), the tail is exact.
    """
    check_formula("DEQUANTIZE", formula)
    scale = np.float32(x_q[0])
    offset = np.float32(np.float32(x_q[1]) * scale)

    def exact(v):
        return quant.dequantize(v, x_q[0], x_q[1])

    def body(v):
        return (v.astype(np.float32) * scale).astype(np.float32) - offset

    if formula == "exact":
        return exact(x)
    return _by_position(vector_width("DEQUANTIZE", formula), body, exact, np.asarray(x))


# ---------------------------------------------------------------------------
# QUANTIZE int8 -> int8


XNNPACK_CONVERT_RANGE = (2.0**-8, 2.0**7)  # s_in / s_out ratios XNNPACK accepts for an int8 -> int8 QUANTIZE


def requantize_int8(x: np.ndarray, x_q: QParams, out_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """QUANTIZE int8 -> int8 (new scale and zero point) by the runtime's ``requantize`` formula.

    ``scalar``: ``quant.requantize`` of ``x - z_in`` under the runtime with a unit weight scale
    (Q31 multiplier of ``s_in / s_out`` from float64 of the float32 scales; the final shift
    rounds ties away from zero or up).  ``tflite_neon16`` (LiteRT optimized): full blocks of 16
    (flattened) ``scalar`` under ``tflite-builtin``, the tail under ``tflite-ref``.
    ``xnnpack_q8``: XNNPACK ``convert``: ``m = rint(256 * float32(s_in / s_out))``,
    ``((x - z_in) * m + 128) >> 8``, plus ``z_out``; outside ``XNNPACK_CONVERT_RANGE`` XNNPACK
    declines the op and LiteRT's optimized kernel runs it (``tflite_neon16``).  ``onnxruntime``
    (a DequantizeLinear -> QuantizeLinear pair): ``quant.quantize`` under ``ort-cpu`` of
    ``quant.dequantize``.
    """
    formula = get_runtime(runtime).requantize
    (si, zi), (so, zo) = x_q, out_q
    ratio = np.float32(np.float32(si) / np.float32(so))
    if formula == "xnnpack_q8" and not XNNPACK_CONVERT_RANGE[0] <= ratio <= XNNPACK_CONVERT_RANGE[1]:
        formula = "tflite_neon16"
    if formula == "tflite_neon16":
        def scalar(name):
            return lambda v: _requantize_scalar(v, x_q, out_q, name)

        return _by_position(vector_width("REQUANTIZE", formula), scalar("tflite-builtin"), scalar("tflite-ref"), x)
    if formula == "onnxruntime":
        return quant.quantize(quant.dequantize(x, si, zi), so, zo, "int8", "ort-cpu")
    if formula == "xnnpack_q8":
        m = int(np.rint(np.float32(256.0) * ratio))
        d = np.asarray(x, dtype=np.int64) - zi
        return _clamp_int8(((d * m + 128) >> 8) + zo, None)
    return _requantize_scalar(x, x_q, out_q, runtime)


def _requantize_scalar(x: np.ndarray, x_q: QParams, out_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """int8 -> int8 as a unit-weight ``quant.requantize`` under the runtime's CONV_2D rule."""
    d = np.asarray(x, dtype=np.int64) - x_q[1]
    return quant.requantize(d, x_q[0], np.float32(1.0), out_q[0], out_q[1], runtime)
