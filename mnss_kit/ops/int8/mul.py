"""Quantized MUL, one formula per runtime."""

from __future__ import annotations

import numpy as np

from ..runtimes import check_formula
from .multiplier import multiply_by_quantized_multiplier, quantize_multiplier
from .ranges import QParams, _clamp_int8
from .rounding import round_float


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
        m, shift = quantize_multiplier(float(real))
        out = multiply_by_quantized_multiplier(product, m, shift, "away_from_zero") + zo
    else:
        scaled = (product.astype(np.float32) * real).astype(np.float32)
        if formula == "xnnpack":
            out = round_float(scaled, "half_even") + zo
        else:
            out = np.rint((scaled + np.float32(zo)).astype(np.float32))
    return _clamp_int8(out, clamp)
