"""Quantized ADD: the four methods the runtimes use (LiteRT reference and optimized, XNNPACK, ONNX
Runtime).  Which one a runtime takes, and how LiteRT's optimized kernel combines two of them by
position in the tensor, is ``vector.add``.
"""

from __future__ import annotations

import numpy as np

from .multiplier import (
    multiply_by_quantized_multiplier,
    multiply_by_quantized_multiplier_single_round,
    quantize_multiplier_smaller_than_one,
)
from .ranges import qrange

ADD_LEFT_SHIFT = {"int8": 20, "int16": 15}


def add(
    a: np.ndarray,
    a_params: tuple[float, int],
    b: np.ndarray,
    b_params: tuple[float, int],
    out_params: tuple[float, int],
    method: str,
    dtype: str = "int8",
    clamp: tuple[int, int] | None = None,
) -> np.ndarray:
    """Quantized ADD of two broadcastable integer tensors; params are ``(scale, zero_point)``.

    ``method`` (one of ``runtimes.ADD_METHODS``):

    ``q31_double_round`` (LiteRT reference)
        Each input, offset by its zero point and shifted left by 20 bits
        (int8), is rescaled to ``2 * max(s_a, s_b)`` with a Q31 multiplier;
        the sum is rescaled to the output scale.  All three rescales use
        double rounding (ties away from zero).
    ``q31_single_round_inputs`` (the vector body of LiteRT's optimized kernel, x86-64)
        As above, but the two input rescales round once, half up:
        ``(x * m + 2^(30 - shift)) >> (31 - shift)``.
    ``xnnpack_fixed_point``
        ``r = s_x / s_o`` in float32; ``shift = 20 - exponent(max(r_a, r_b))``;
        ``m_x = rint(r_x * 2^shift)``; the int32 sum
        ``2^(shift-1) - m_a z_a - m_b z_b + m_a a + m_b b`` is shifted right
        arithmetically by ``shift`` (ties toward +infinity).
    ``float32_fma`` (ONNX Runtime MLAS)
        ``r_x = s_x / s_o`` and ``bias = z_o - fma(r_a, z_a, r_b z_b)`` in float32;
        ``rint(fma(a, r_a, fma(b, r_b, bias)))`` (round half to even), with
        ``a``, ``b`` the raw integers.
    """
    (sa, za), (sb, zb), (so, zo) = a_params, b_params, out_params
    sa, sb, so = np.float32(sa), np.float32(sb), np.float32(so)
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    if method in ("q31_double_round", "q31_single_round_inputs"):
        left = ADD_LEFT_SHIFT[np.dtype(dtype).name]
        twice_max = 2.0 * max(float(sa), float(sb))
        ma, sha = quantize_multiplier_smaller_than_one(float(sa) / twice_max)
        mb, shb = quantize_multiplier_smaller_than_one(float(sb) / twice_max)
        mo, sho = quantize_multiplier_smaller_than_one(twice_max / ((1 << left) * float(so)))
        if method == "q31_double_round":
            scaled_a = multiply_by_quantized_multiplier((a - za) << left, ma, sha, "away_from_zero")
            scaled_b = multiply_by_quantized_multiplier((b - zb) << left, mb, shb, "away_from_zero")
        else:
            scaled_a = multiply_by_quantized_multiplier_single_round((a - za) << left, ma, sha)
            scaled_b = multiply_by_quantized_multiplier_single_round((b - zb) << left, mb, shb)
        out = multiply_by_quantized_multiplier(scaled_a + scaled_b, mo, sho, "away_from_zero") + zo
    elif method == "xnnpack_fixed_point":
        ra, rb = np.float32(sa / so), np.float32(sb / so)
        exponent = int(np.array(max(ra, rb), dtype=np.float32).view(np.uint32) >> 23) - 127
        shift = 20 - exponent
        ma = int(np.rint(np.float64(ra) * 2.0**shift))  # exact power-of-two scaling, then round half even
        mb = int(np.rint(np.float64(rb) * 2.0**shift))
        bias = (1 << (shift - 1)) - ma * za - mb * zb
        out = ((bias + a * ma + b * mb) >> shift) + zo
    elif method == "float32_fma":
        ra, rb = np.float32(sa / so), np.float32(sb / so)
        bias = np.float32(np.float32(zo) - fma_f32(ra, np.float32(za), np.float32(rb * np.float32(zb))))
        inner = fma_f32(b.astype(np.float32), rb, bias)
        out = np.rint(fma_f32(a.astype(np.float32), ra, inner))  # round half to even
    else:
        raise ValueError(f"unknown add method {method!r}")
    lo, hi = clamp if clamp is not None else qrange(dtype)
    return np.clip(out, lo, hi).astype(dtype)


def fma_f32(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Fused multiply-add of float32 values, rounded once to float32.

    Emulated in float64: the product of two float32 is exact there, and the
    sum is rounded first to float64 and then to float32, which can only
    differ from a true single rounding when the float64 result sits exactly
    on a float32 tie (not reachable with int8 operands and scales in use).
    """
    a, b, c = (np.asarray(v, dtype=np.float64) for v in (a, b, c))
    return (a * b + c).astype(np.float32)
