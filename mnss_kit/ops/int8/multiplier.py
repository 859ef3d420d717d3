"""Requantization multipliers: the real ``s_in * s_w[c] / s_out`` as a runtime computes it, its
Q31 mantissa and power-of-two shift (TFLite ``QuantizeMultiplier``), and
``MultiplyByQuantizedMultiplier``, the integer product with the runtime's final shift rounding.
"""

from __future__ import annotations

import math

import numpy as np

from ..runtimes import Runtime
from .ranges import INT32_MAX
from .rounding import round_float, rounding_divide_by_pot, rounding_shift_half_up, saturating_rounding_doubling_high_mul


def quantize_multiplier(real_multiplier: float) -> tuple[int, int]:
    """TFLite ``QuantizeMultiplier``: ``real ~= m * 2^(shift - 31)`` with ``m`` in [2^30, 2^31).

    ``real_multiplier`` is a float64 computed by the caller (TFLite builds it in
    double from the float32 scales).  Returns ``(m, shift)``; ``shift > 0`` is a
    left shift.  Values below 2^-32 flush to ``(0, 0)``.
    """
    if real_multiplier == 0.0:
        return 0, 0
    if real_multiplier < 0.0:
        raise ValueError("multipliers are non-negative")
    fraction, shift = math.frexp(real_multiplier)  # fraction in [0.5, 1)
    q = int(round_float(fraction * (1 << 31), "away_from_zero"))
    if q == 1 << 31:
        q //= 2
        shift += 1
    if shift < -31:
        return 0, 0
    if shift > 30:
        return INT32_MAX, 30
    return q, shift


def quantize_multiplier_smaller_than_one(real_multiplier: float) -> tuple[int, int]:
    """TFLite ``QuantizeMultiplierSmallerThanOneExp``: as :func:`quantize_multiplier` for ``real < 1``; shift <= 0."""
    if not 0.0 <= real_multiplier < 1.0:
        raise ValueError(f"multiplier {real_multiplier} is not in [0, 1)")
    return quantize_multiplier(real_multiplier)


def effective_multiplier(input_scale: float, weight_scales: np.ndarray, output_scale: float, runtime: Runtime) -> np.ndarray:
    """Per-channel real multiplier ``s_in * s_w[c] / s_out`` as the runtime computes it.

    ``q31`` runtimes compute in float64 from the float32 scales (TFLite
    ``PopulateConvolutionQuantizationParams``); ``float32`` runtimes compute
    ``(s_in * s_w) / s_out`` with float32 rounding after each operation.
    Returns float64 (q31) or float32 (float32) array of shape ``(C,)``.
    """
    s_w = np.atleast_1d(np.asarray(weight_scales, dtype=np.float32))
    if runtime.multiplier == "q31":
        return np.float64(np.float32(input_scale)) * s_w.astype(np.float64) / np.float64(np.float32(output_scale))
    product = (np.float32(input_scale) * s_w).astype(np.float32)
    return (product / np.float32(output_scale)).astype(np.float32)


def multiply_by_quantized_multiplier(x: np.ndarray, multiplier: np.ndarray, shift: np.ndarray, shift_rounding: str) -> np.ndarray:
    """TFLite ``MultiplyByQuantizedMultiplier`` on int32 values: ``x * m * 2^(shift-31)``.

    ``x`` int32 values (int64 array ok); ``multiplier`` (int32 Q31) and ``shift``
    broadcast against ``x`` (per channel on the last axis).  A positive shift is
    applied as a left shift before the high multiply, a negative one as a
    rounding right shift after it.  Returns int64 holding int32 values.
    """
    x = np.asarray(x, dtype=np.int64)
    shift = np.asarray(shift, dtype=np.int64)
    left = np.maximum(shift, 0)
    right = np.maximum(-shift, 0)
    # The left-shifted value is an int32 in the runtimes; wrap like two's complement.
    shifted = ((x << left) + (1 << 31)) % (1 << 32) - (1 << 31)
    high = saturating_rounding_doubling_high_mul(shifted, multiplier)
    if shift_rounding == "away_from_zero":
        return rounding_divide_by_pot(high, right)
    if shift_rounding == "half_up":
        return rounding_shift_half_up(high, right)
    raise ValueError(f"unknown shift rounding {shift_rounding!r}")


def multiply_by_quantized_multiplier_single_round(x: np.ndarray, multiplier: int, shift: int) -> np.ndarray:
    """``round(x * m / 2^(31 - shift))`` rounded once, ties toward +infinity.  ``shift <= 0``; int64 result."""
    x = np.asarray(x, dtype=np.int64)
    total = 31 - int(shift)
    # |x| < 2^31 and m < 2^31, so x * m fits int64.
    return (x * np.int64(multiplier) + (np.int64(1) << (total - 1))) >> total
