"""Per-runtime integer formulas of the int8 ops beyond convolution (reference definitions).

``mnss_kit.ops.quant`` defines quantize/dequantize and the requantization
of CONV_2D per runtime profile; this module adds the ops whose formulas
differ in other ways.  Each function takes a *formula name* (plain data,
chosen per kernel set by ``mnss_kit.emulate.profiles``) and states what the
runtime does, as found in LiteRT's and XNNPACK's sources and checked bit for
bit against ai-edge-litert 2.3.0 on x86-64 (tests/emulate).

Two things a reader would not guess:

* LiteRT's "optimized" builtin kernels on x86 are its ARM NEON code compiled
  through an SSE emulation of the NEON intrinsics.  Vector loops process 16
  (ADD) or 8 (DEPTHWISE output stage) values at a time with NEON rounding,
  and the leftover tail runs the scalar reference formula.  Where a value
  sits in the tensor therefore decides its rounding.
* ``SaturatingRoundingDoublingHighMul`` (and NEON ``vqrdmulh``) round ties
  toward +infinity, not away from zero; ``RoundingDivideByPOT`` rounds ties
  away from zero.

All arithmetic is in int64 or in explicitly float32 numpy arrays.
"""

from __future__ import annotations

import numpy as np

from . import quant

INT8_MIN, INT8_MAX = quant.INT8_MIN, quant.INT8_MAX
ADD_LEFT_SHIFT = quant.ADD_LEFT_SHIFT["int8"]
ADD_VECTOR_WIDTH = 16  # values per NEON iteration of LiteRT's optimized int8 ADD


def _clamp_int8(x: np.ndarray, clamp: tuple[int, int] | None) -> np.ndarray:
    lo, hi = clamp if clamp is not None else (INT8_MIN, INT8_MAX)
    return np.clip(x, lo, hi).astype(np.int8)


def rounding_doubling_high_mul_neon(a: np.ndarray, b: int) -> np.ndarray:
    """NEON ``vqrdmulh``: ``(2ab + 2^31) >> 32`` saturated, i.e. ``round(ab / 2^31)`` with ties up.

    ``a`` int32 values (int64 array), ``b`` an int32 multiplier.  Returns int64.
    """
    product = np.asarray(a, dtype=np.int64) * np.int64(b)  # |product| < 2^62
    high = (2 * product + (1 << 31)) >> 32
    return np.clip(high, quant.INT32_MIN, quant.INT32_MAX)


# ---------------------------------------------------------------------------
# ADD


def _add_multipliers(sa: float, sb: float, so: float) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int]]:
    """LiteRT ADD Prepare: rescale both inputs to ``2 * max(s_a, s_b)`` and that to the output (float64 from float32)."""
    twice_max = 2.0 * max(sa, sb)
    return (quant.quantize_multiplier_smaller_than_one(sa / twice_max),
            quant.quantize_multiplier_smaller_than_one(sb / twice_max),
            quant.quantize_multiplier_smaller_than_one(twice_max / ((1 << ADD_LEFT_SHIFT) * so)))


def _add_neon(a: np.ndarray, b: np.ndarray, sa: float, sb: float, so: float, zo: int) -> np.ndarray:
    """LiteRT optimized int8 ADD, vector body: a truncating shift by ``20 + input_shift``, then ``vqrdmulh``.

    ``a``, ``b`` int64 values already offset by their zero points.  The output
    multiplier is applied with ``vqrdmulh`` and ``RoundingDivideByPOT``.
    """
    (ma, sha), (mb, shb), (mo, sho) = _add_multipliers(sa, sb, so)
    scaled_a = rounding_doubling_high_mul_neon((a << ADD_LEFT_SHIFT) >> -sha, ma)
    scaled_b = rounding_doubling_high_mul_neon((b << ADD_LEFT_SHIFT) >> -shb, mb)
    total = rounding_doubling_high_mul_neon(scaled_a + scaled_b, mo)
    return quant.rounding_divide_by_pot(total, -sho) + zo


def _add_reference(a: np.ndarray, b: np.ndarray, sa: float, sb: float, so: float, zo: int) -> np.ndarray:
    """LiteRT reference int8 ADD on offset inputs (see ``quant.add``)."""
    (ma, sha), (mb, shb), (mo, sho) = _add_multipliers(sa, sb, so)
    scaled_a = quant.multiply_by_quantized_multiplier(a << ADD_LEFT_SHIFT, ma, sha, "away_from_zero")
    scaled_b = quant.multiply_by_quantized_multiplier(b << ADD_LEFT_SHIFT, mb, shb, "away_from_zero")
    return quant.multiply_by_quantized_multiplier(scaled_a + scaled_b, mo, sho, "away_from_zero") + zo


ADD_FORMULAS = ("tflite_reference", "tflite_neon16", "float32")


def add(a: np.ndarray, a_q: tuple[float, int], b: np.ndarray, b_q: tuple[float, int], out_q: tuple[float, int],
        formula: str, clamp: tuple[int, int] | None = None) -> np.ndarray:
    """Quantized ADD of two int8 tensors of one shape -> int8.

    ``tflite_reference``: ``quant.add`` with the q31 profile.
    ``tflite_neon16``: LiteRT optimized kernel; the flattened tensor is cut
    into blocks of 16, full blocks take :func:`_add_neon`, the tail the reference.
    ``float32``: XNNPACK (``quant.add`` with a float32 profile).
    """
    if formula == "tflite_reference":
        return quant.add(a, a_q, b, b_q, out_q, "tflite_reference", clamp=clamp)
    if formula == "float32":
        return quant.add(a, a_q, b, b_q, out_q, "xnnpack", clamp=clamp)
    if formula != "tflite_neon16":
        raise ValueError(f"unknown ADD formula {formula!r}")
    a, b = np.broadcast_arrays(np.asarray(a), np.asarray(b))
    sa, sb, so = (float(np.float32(q[0])) for q in (a_q, b_q, out_q))
    fa = a.reshape(-1).astype(np.int64) - a_q[1]
    fb = b.reshape(-1).astype(np.int64) - b_q[1]
    body = fa.size // ADD_VECTOR_WIDTH * ADD_VECTOR_WIDTH
    out = np.empty(fa.size, dtype=np.int64)
    out[:body] = _add_neon(fa[:body], fb[:body], sa, sb, so, out_q[1])
    out[body:] = _add_reference(fa[body:], fb[body:], sa, sb, so, out_q[1])
    return _clamp_int8(out.reshape(a.shape), clamp)


# ---------------------------------------------------------------------------
# MUL

MUL_FORMULAS = ("tflite", "float32")


def mul(a: np.ndarray, a_q: tuple[float, int], b: np.ndarray, b_q: tuple[float, int], out_q: tuple[float, int],
        formula: str, clamp: tuple[int, int] | None = None) -> np.ndarray:
    """Quantized MUL of two int8 tensors of one shape -> int8.

    ``tflite`` (reference and optimized alike): the real multiplier
    ``s_a * s_b / s_o`` is evaluated in float32 (LiteRT multiplies the float
    scales before widening to double), turned into a Q31 multiplier, and
    applied to ``(a - z_a) * (b - z_b)`` with ``MultiplyByQuantizedMultiplier``
    (double rounding).  ``float32`` (XNNPACK): ``float32(product) * float32(s_a * s_b / s_o)``
    rounded half to even.
    """
    (sa, za), (sb, zb), (so, zo) = a_q, b_q, out_q
    real = np.float32(np.float32(np.float32(sa) * np.float32(sb)) / np.float32(so))
    product = (np.asarray(a, dtype=np.int64) - za) * (np.asarray(b, dtype=np.int64) - zb)  # |p| <= 65025
    if formula == "tflite":
        m, shift = quant.quantize_multiplier(float(real))
        out = quant.multiply_by_quantized_multiplier(product, m, shift, "away_from_zero")
    elif formula == "float32":
        out = quant.round_float((product.astype(np.float32) * real).astype(np.float32), "half_even")
    else:
        raise ValueError(f"unknown MUL formula {formula!r}")
    return _clamp_int8(out + zo, clamp)


# ---------------------------------------------------------------------------
# LOGISTIC, TANH: every kernel set builds a 256-entry table in float32


def logistic(x: np.ndarray, x_q: tuple[float, int], profile: str) -> np.ndarray:
    """int8 LOGISTIC through ``quant.lookup_table`` of ``quant.sigmoid_f32``; output params (1/256, -128)."""
    with np.errstate(over="ignore"):  # exp overflow gives 1/inf = 0, the right limit
        table = quant.lookup_table(quant.sigmoid_f32, x_q, quant.LOGISTIC_OUTPUT, profile)
    return quant.apply_table(x, table)


def tanh(x: np.ndarray, x_q: tuple[float, int], profile: str) -> np.ndarray:
    """int8 TANH through ``quant.lookup_table`` of ``quant.tanh_f32``; output params (1/128, 0)."""
    return quant.apply_table(x, quant.lookup_table(quant.tanh_f32, x_q, quant.TANH_OUTPUT, profile))


# ---------------------------------------------------------------------------
# AVERAGE_POOL_2D

def average_pool_divide(total: np.ndarray, count: np.ndarray, formula: str) -> np.ndarray:
    """Window sum of raw int8 values / number of valid inputs (int64 arrays, broadcastable) -> int64.

    ``tflite`` (every LiteRT kernel set; XNNPACK does not take int8
    AVERAGE_POOL_2D): ``quant.average_pool_round``, ties away from zero.
    """
    if formula == "tflite":
        return quant.average_pool_round(total, np.asarray(count, dtype=np.int64))
    raise ValueError(f"unknown AVERAGE_POOL_2D formula {formula!r}")


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


RESIZE_FORMULAS = ("tflite", "xnnpack_q11")


def resize_bilinear(x: np.ndarray, out_hw: tuple[int, int], half_pixel_centers: bool, formula: str) -> np.ndarray:
    """int8 RESIZE_BILINEAR (align_corners False), (N, H, W, C) -> (N, Ho, Wo, C); params unchanged.

    ``tflite``: LiteRT ``ResizeBilinearInteger``: positions in 1/1024 pixel, the
    four weights multiply in int64 and the sum (in 2^-20 units) is rounded
    half away from zero.  ``xnnpack_q11``: :func:`_resize_xnnpack`.
    """
    if formula == "xnnpack_q11":
        return _resize_xnnpack(x, out_hw, half_pixel_centers)
    if formula != "tflite":
        raise ValueError(f"unknown RESIZE_BILINEAR formula {formula!r}")
    n, h, w, c = x.shape
    y0, y1, fy = _tflite_source_10bit(out_hw[0], h, half_pixel_centers)
    x0, x1, fx = _tflite_source_10bit(out_hw[1], w, half_pixel_centers)
    v = np.asarray(x, dtype=np.int64)
    wy1, wy0 = fy[:, None, None], (1024 - fy)[:, None, None]
    wx1, wx0 = fx[None, :, None], (1024 - fx)[None, :, None]
    top = v[:, y0][:, :, x0] * wx0 + v[:, y0][:, :, x1] * wx1
    bottom = v[:, y1][:, :, x0] * wx0 + v[:, y1][:, :, x1] * wx1
    total = top * wy0 + bottom * wy1  # value in 2^-20 units
    half = 1 << 19
    out = np.where(total > 0, (total + half) >> 20, -((-total + half) >> 20))
    return out.astype(np.int8)


# ---------------------------------------------------------------------------
# QUANTIZE float32 -> int8, DEQUANTIZE int8 -> float32

QUANTIZE_VECTOR_WIDTH = 8  # values per NEON iteration of LiteRT's optimized QUANTIZE / DEQUANTIZE


def quantize(x: np.ndarray, out_q: tuple[float, int], formula: str) -> np.ndarray:
    """QUANTIZE float32 -> int8.

    ``tflite_reference`` / ``xnnpack``: ``quant.quantize`` with that profile.
    ``tflite_neon8``: LiteRT optimized kernel; full blocks of 8 (flattened)
    multiply by the float32 reciprocal of the scale and round half to even,
    the tail divides in float64 and rounds half away from zero.
    """
    if formula in ("tflite_reference", "xnnpack"):
        return quant.quantize(x, out_q[0], out_q[1], "int8", formula)
    if formula != "tflite_neon8":
        raise ValueError(f"unknown QUANTIZE formula {formula!r}")
    flat = np.asarray(x, dtype=np.float32).reshape(-1)
    scale = np.float32(out_q[0])
    body = flat.size // QUANTIZE_VECTOR_WIDTH * QUANTIZE_VECTOR_WIDTH
    q = np.empty(flat.size, dtype=np.float64)
    q[:body] = np.rint((flat[:body] * (np.float32(1.0) / scale)).astype(np.float32))
    q[body:] = quant.round_float(flat[body:].astype(np.float64) / np.float64(scale), "away_from_zero")
    return _clamp_int8(q.reshape(np.shape(x)) + out_q[1], None)


def dequantize(x: np.ndarray, x_q: tuple[float, int], formula: str) -> np.ndarray:
    """DEQUANTIZE int8 -> float32.

    ``exact``: ``quant.dequantize``, one rounding of ``scale * (q - zp)``.
    ``tflite_neon8``: LiteRT optimized kernel; full blocks of 8 compute
    ``float32(q) * scale - float32(zp * scale)`` (two roundings), the tail is exact.
    """
    if formula == "exact":
        return quant.dequantize(x, x_q[0], x_q[1])
    if formula != "tflite_neon8":
        raise ValueError(f"unknown DEQUANTIZE formula {formula!r}")
    flat = np.asarray(x).reshape(-1)
    scale = np.float32(x_q[0])
    body = flat.size // QUANTIZE_VECTOR_WIDTH * QUANTIZE_VECTOR_WIDTH
    out = np.empty(flat.size, dtype=np.float32)
    offset = np.float32(np.float32(x_q[1]) * scale)
    out[:body] = (flat[:body].astype(np.float32) * scale).astype(np.float32) - offset
    out[body:] = quant.dequantize(flat[body:], x_q[0], x_q[1])
    return out.reshape(np.shape(x))


# ---------------------------------------------------------------------------
# QUANTIZE int8 -> int8


XNNPACK_CONVERT_RANGE = (2.0**-8, 2.0**7)  # s_in / s_out ratios XNNPACK accepts for an int8 -> int8 QUANTIZE
REQUANTIZE_VECTOR_WIDTH = 16  # values per NEON iteration of LiteRT's optimized int8 -> int8 QUANTIZE


def requantize_int8(x: np.ndarray, x_q: tuple[float, int], out_q: tuple[float, int], formula: str) -> np.ndarray:
    """QUANTIZE int8 -> int8 (new scale and zero point).

    ``tflite_reference`` / ``tflite_half_up``: ``MultiplyByQuantizedMultiplier(x - z_in, Q31(s_in / s_out)) + z_out``,
    the multiplier from float64 of the float32 scales, the final shift
    rounding ties away from zero or up.  ``tflite_neon16`` (LiteRT optimized):
    full blocks of 16 (flattened) ``tflite_half_up``, the tail ``tflite_reference``.
    ``xnnpack_q8``: XNNPACK ``convert``: ``m = rint(256 * float32(s_in / s_out))``,
    ``((x - z_in) * m + 128) >> 8``, plus ``z_out``.  Outside
    ``XNNPACK_CONVERT_RANGE`` XNNPACK declines the op and LiteRT's optimized
    kernel runs it (``tflite_neon16``).
    """
    if formula == "tflite_neon16":
        flat = np.asarray(x).reshape(-1)
        body = flat.size // REQUANTIZE_VECTOR_WIDTH * REQUANTIZE_VECTOR_WIDTH
        out8 = np.concatenate([requantize_int8(flat[:body], x_q, out_q, "tflite_half_up"),
                               requantize_int8(flat[body:], x_q, out_q, "tflite_reference")])
        return out8.reshape(np.shape(x))
    (si, zi), (so, zo) = x_q, out_q
    d = np.asarray(x, dtype=np.int64) - zi
    ratio = np.float32(np.float32(si) / np.float32(so))
    if formula == "xnnpack_q8" and not XNNPACK_CONVERT_RANGE[0] <= ratio <= XNNPACK_CONVERT_RANGE[1]:
        return requantize_int8(x, x_q, out_q, "tflite_neon16")
    if formula in ("tflite_reference", "tflite_half_up"):
        m, shift = quant.quantize_multiplier(float(np.float32(si)) / float(np.float32(so)))
        rounding = "away_from_zero" if formula == "tflite_reference" else "half_up"
        out = quant.multiply_by_quantized_multiplier(d, m, shift, rounding)
    elif formula == "xnnpack_q8":
        m = int(np.rint(np.float32(256.0) * ratio))
        out = (d * m + 128) >> 8
    else:
        raise ValueError(f"unknown int8 requantize formula {formula!r}")
    return _clamp_int8(out + zo, None)
