"""Faster, bit-identical convolutions and elementwise ops for the emulator's NPU stage.

``ops.int8.requantize.requantize`` is the readable definition of each runtime's
requantization; under the LiteRT runtimes (Q31 multiplier and shift) it makes
a dozen int64 passes with divisions, ``np.where`` and modulo, about 190 ns per
value, which dominates a 720p frame.  :class:`Requantizer` computes the same
integers with a few in-place int64 passes (about 10x faster) by using two
facts:

* The multiplier ``m`` is never negative and never ``-2^31``, so gemmlowp's
  ``SaturatingRoundingDoublingHighMul(x, m)`` (nudge, then C division by
  ``2^31``) equals ``(x * m + 2^30) >> 31`` with an arithmetic shift: both
  round ``x * m / 2^31`` to nearest with ties toward +infinity, and the
  saturating case cannot occur.  ``|x| < 2^31`` and ``m < 2^31`` keep
  ``x * m`` inside int64.
* ``RoundingDivideByPOT(x, r)`` (ties away from zero) equals
  ``(x + 2^(r-1) - [x < 0]) >> r`` for ``r > 0``; the half-up shift of the
  optimized kernels is ``(x + 2^(r-1)) >> r``.

The accumulator is wrapped to int32 before the left shift, exactly as the
runtimes' int32 arithmetic (and ``quant.multiply_by_quantized_multiplier``)
does; the wrap is skipped when the caller knows the values fit.  Float32
runtimes (XNNPACK, ONNX Runtime) are already a couple of vector passes and
use ``quant.requantize`` unchanged.

:func:`conv2d` runs a convolution in blocks of output rows: the definition's exact
accumulation (``kernels.conv_accumulators``) on each block, then the requantization while the
block's int64 accumulators are still in cache (whole-frame int64 passes were memory bound).

ADD and MUL of two int8 tensors have only 65536 distinct operand pairs: :class:`PairTable`
evaluates the kernel once on every pair and looks results up (about 10x faster on a 720p
frame).  That is exact whenever the kernel's result depends on the two values only, which
holds for every formula except a vector formula (``ops.int8.vector.vector_width``, LiteRT's optimized
ADD) on a tensor whose size is not a multiple of its vector width (the tail rounds
differently); that case keeps the kernel.
``tests/emulate/test_frame_loop_fast.py`` asserts equality with the definitions for every
runtime.
"""

from __future__ import annotations

import numpy as np

from ..ops.int8.multiplier import effective_multiplier, quantize_multiplier
from ..ops.int8.requantize import activation_bounds, requantize
from ..ops.int8.vector import vector_width
from ..ops.runtimes import Runtime, get_runtime
from . import kernels

QParams = kernels.QParams
_INT32_SPAN = 1 << 32
_INT32_OFFSET = 1 << 31


class Requantizer:
    """int32 accumulators ``(..., C)`` of one convolution -> int8, for fixed scales and one runtime.

    ``x_q``/``out_q``: ``(scale, zero_point)``; ``w_scales`` (C,) float32;
    ``activation`` a fused activation name; ``runtime`` an ``ops.runtimes`` runtime (or name)
    whose CONV_2D requantization rule applies.
    """

    def __init__(self, x_q: QParams, w_scales: np.ndarray, out_q: QParams, activation: str, runtime: str | Runtime):
        self.x_q, self.out_q = x_q, out_q
        self.w_scales = np.atleast_1d(np.asarray(w_scales, dtype=np.float32))
        self.runtime = profile = get_runtime(runtime)
        self.clamp = activation_bounds(activation, out_q[0], out_q[1])
        self.q31 = profile.multiplier == "q31"
        if not self.q31:
            return
        real = effective_multiplier(x_q[0], self.w_scales, out_q[0], profile)
        pairs = [quantize_multiplier(float(r)) for r in real]
        shift = np.array([s for _, s in pairs], dtype=np.int64)
        self.multiplier = np.array([m for m, _ in pairs], dtype=np.int64)
        self.left = np.maximum(shift, 0)
        right = np.maximum(-shift, 0)
        self.right = right
        self.half = np.where(right > 0, np.int64(1) << np.maximum(right - 1, 0), 0)
        # ties away from zero: one less for negative values (applied as ``sign_mask & -1``)
        away = profile.shift_rounding == "away_from_zero"
        if profile.shift_rounding not in ("away_from_zero", "half_up"):
            raise ValueError(f"unknown shift rounding {profile.shift_rounding!r}")
        self.negative_adjust = np.where((right > 0) & away, np.int64(-1), np.int64(0))
        self.any_left = bool(np.any(self.left))
        self.any_adjust = bool(np.any(self.negative_adjust))

    def __call__(self, acc: np.ndarray, fits_int32: bool = False) -> np.ndarray:
        """``acc`` int64 (..., C) (overwritten) -> int8.  ``fits_int32``: every value is known to be an int32."""
        if not self.q31:
            return requantize(acc, self.x_q[0], self.w_scales, self.out_q[0], self.out_q[1], self.runtime, clamp=self.clamp)
        x = acc if acc.dtype == np.int64 else acc.astype(np.int64)
        if self.any_left:
            x <<= self.left
        if self.any_left or not fits_int32:  # the runtimes hold x << left in an int32
            x += _INT32_OFFSET
            x &= _INT32_SPAN - 1
            x -= _INT32_OFFSET
        x *= self.multiplier
        x += np.int64(1 << 30)
        x >>= 31  # SaturatingRoundingDoublingHighMul, ties toward +infinity
        if self.any_adjust:
            x += self.half + ((x >> 63) & self.negative_adjust)
        else:
            x += self.half
        x >>= self.right
        x += self.out_q[1]
        np.clip(x, self.clamp[0], self.clamp[1], out=x)
        return x.astype(np.int8)


def fits_int32(k: int, bias: np.ndarray | None) -> bool:
    """True if every accumulator of a length-``k`` int8 dot product plus ``bias`` is an int32."""
    bound = k * (255 * 128) + (int(np.max(np.abs(bias.astype(np.int64)))) if bias is not None and bias.size else 0)
    return bound < 2**31


_BLOCK_VALUES = 1 << 18  # accumulators per block of output rows (2 MB of int64): a cache-sized working set


def conv2d(x: np.ndarray, x_q: QParams, weights: np.ndarray, bias: np.ndarray | None, requantizer: Requantizer,
           stride: int = 1, padding: str = "SAME") -> np.ndarray:
    """``kernels.conv2d`` with a prepared :class:`Requantizer`: (N,H,W,Ci) int8 -> (N,Ho,Wo,Co) int8.

    The output is computed in blocks of rows, each through ``kernels.conv_accumulators`` (the
    same exact sums) and requantized while its int64 accumulators are still in cache; the
    input is padded once with its zero point, which contributes ``x - x_zp = 0`` exactly as the
    definition's zero padding of ``x - x_zp`` does.
    """
    co, kh, kw, ci = weights.shape
    n, h, w, _ = x.shape
    ho, top = kernels.output_size(h, kh, stride, padding)
    wo, left = kernels.output_size(w, kw, stride, padding)
    rows_in, cols_in = (ho - 1) * stride + kh, (wo - 1) * stride + kw
    padded = np.full((n, max(rows_in, h + top), max(cols_in, w + left), ci), x_q[1], dtype=np.int8)
    padded[:, top:top + h, left:left + w] = x
    safe = fits_int32(kh * kw * ci, bias)
    out = np.empty((n, ho, wo, co), dtype=np.int8)
    rows = max(1, _BLOCK_VALUES // (n * wo * co))
    for y0 in range(0, ho, rows):
        y1 = min(ho, y0 + rows)
        window = padded[:, y0 * stride:(y1 - 1) * stride + kh, :cols_in]
        out[:, y0:y1] = requantizer(kernels.conv_accumulators(window, x_q[1], weights, bias, stride, "VALID"), safe)
    return out


class DepthwiseRequantizers:
    """The body / tail requantizers of ``kernels.depthwise_conv2d`` under one runtime."""

    def __init__(self, x_q: QParams, w_scales: np.ndarray, out_q: QParams, activation: str, channels: int,
                 runtime: str | Runtime):
        rt = get_runtime(runtime)
        scales = np.broadcast_to(np.asarray(w_scales, dtype=np.float32), (channels,))
        width = rt.depthwise_vector_channels
        self.body = channels // width * width if width else channels
        self.head = Requantizer(x_q, scales[:self.body], out_q, activation, rt) if self.body else None
        self.tail = Requantizer(x_q, scales[self.body:], out_q, activation, rt.depthwise_tail) if self.body < channels else None


def depthwise_conv2d(x: np.ndarray, x_q: QParams, weights: np.ndarray, bias: np.ndarray | None,
                     requantizers: DepthwiseRequantizers, stride: int = 1, padding: str = "SAME") -> np.ndarray:
    """``kernels.depthwise_conv2d`` with prepared requantizers: (N,H,W,Ci) int8 -> (N,Ho,Wo,Co) int8."""
    acc = kernels.depthwise_accumulators(x, x_q[1], weights, bias, stride, padding)
    safe = fits_int32(weights.shape[1] * weights.shape[2], bias)
    out = np.empty(acc.shape, dtype=np.int8)
    body = requantizers.body
    if requantizers.head is not None:
        out[..., :body] = requantizers.head(np.ascontiguousarray(acc[..., :body]), safe)
    if requantizers.tail is not None:
        out[..., body:] = requantizers.tail(np.ascontiguousarray(acc[..., body:]), safe)
    return out


_ALL_PAIRS = (np.repeat(np.arange(-128, 128), 256).astype(np.int8), np.tile(np.arange(-128, 128), 256).astype(np.int8))


class PairTable:
    """An int8 binary op (``kernels.add`` / ``kernels.mul``) as a 256x256 lookup table.

    ``kernel(a, a_q, b, b_q, out_q, activation, runtime)``; see the module docstring for when
    a table is exact (:func:`pair_table_is_exact`).
    """

    def __init__(self, kernel, a_q: QParams, b_q: QParams, out_q: QParams, activation: str, runtime: Runtime):
        a, b = _ALL_PAIRS  # 65536 values: a multiple of every vector width, so all take the vector body
        self.table = kernel(a, a_q, b, b_q, out_q, activation, runtime).reshape(-1)

    def __call__(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``a``, ``b`` int8 of one shape -> int8 of that shape."""
        index = a.view(np.uint8).astype(np.uint16) ^ np.uint16(0x80)
        index <<= 8
        index |= b.view(np.uint8) ^ np.uint8(0x80)
        return self.table[index]


def pair_table_is_exact(kind: str, runtime: Runtime, size: int) -> bool:
    """True if ``kind`` (ADD or MUL) under ``runtime`` on ``size`` values depends on the operand values only."""
    width = vector_width(kind, runtime.formula(kind))
    return width == 0 or size % width == 0
