"""Rounding primitives of the int8 ops (vectorized; exact in int64 / float64).

Float rounding by a named tie rule (:func:`round_float`), and the fixed-point steps of gemmlowp
that LiteRT's kernels use: ``SaturatingRoundingDoublingHighMul`` (ties toward +infinity) and
``RoundingDivideByPOT`` (ties away from zero), plus the half-up shift of LiteRT's optimized kernels.
"""

from __future__ import annotations

import numpy as np

from .ranges import INT32_MAX, INT32_MIN


def round_float(x: np.ndarray, rounding: str) -> np.ndarray:
    """Round float values to integers (float64 result) with the named tie rule."""
    x = np.asarray(x, dtype=np.float64)
    if rounding == "half_even":
        return np.rint(x)
    if rounding == "away_from_zero":  # C/C++ std::round
        return np.sign(x) * np.floor(np.abs(x) + 0.5)
    if rounding == "half_up":
        return np.floor(x + 0.5)
    raise ValueError(f"unknown rounding {rounding!r}")


def _trunc_div(a: np.ndarray, d: int) -> np.ndarray:
    """C integer division (rounds toward zero) of int64 ``a`` by positive ``d``."""
    q = np.abs(a) // d
    return np.where(a < 0, -q, q)


def saturating_rounding_doubling_high_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """gemmlowp ``SaturatingRoundingDoublingHighMul``: ``round(a * b / 2^31)``, ties toward +infinity.

    (gemmlowp adds a nudge of ``2^30`` or ``1 - 2^30`` and divides with C
    truncation, so -1.5 becomes -1 and 1.5 becomes 2.)

    ``a``, ``b``: int32 values (any integer dtype, broadcastable).  Returns int64
    holding int32 values; the one overflow case ``a = b = -2^31`` saturates to
    ``2^31 - 1``.
    """
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    ab = a * b  # |ab| <= 2^62: fits int64
    nudge = np.where(ab >= 0, np.int64(1 << 30), np.int64(1 - (1 << 30)))
    high = _trunc_div(ab + nudge, 1 << 31)
    overflow = (a == INT32_MIN) & (b == INT32_MIN)
    return np.where(overflow, np.int64(INT32_MAX), high)


def rounding_divide_by_pot(x: np.ndarray, exponent: np.ndarray) -> np.ndarray:
    """gemmlowp ``RoundingDivideByPOT``: ``round(x / 2^exponent)``, ties away from zero.

    ``x`` int64 holding int32 values, ``exponent`` in [0, 31] (broadcastable).
    """
    x = np.asarray(x, dtype=np.int64)
    exponent = np.asarray(exponent, dtype=np.int64)
    mask = (np.int64(1) << exponent) - 1
    remainder = x & mask
    threshold = (mask >> 1) + (x < 0)
    return (x >> exponent) + (remainder > threshold)


def rounding_shift_half_up(x: np.ndarray, exponent: np.ndarray) -> np.ndarray:
    """``(x + 2^(exponent-1)) >> exponent`` (arithmetic shift): ties toward +infinity; exponent 0 is identity."""
    x = np.asarray(x, dtype=np.int64)
    exponent = np.asarray(exponent, dtype=np.int64)
    half = np.where(exponent > 0, np.int64(1) << np.maximum(exponent - 1, 0), 0)
    return (x + half) >> exponent
