"""Requantization: an int32 accumulator (CONV_2D, DEPTHWISE_CONV_2D) or an int8 tensor (QUANTIZE
int8 -> int8) to a new scale and zero point, by each runtime's formula.

The accumulator is multiplied by ``s_in * s_w[c] / s_out``, rounded, offset by the output zero
point and clamped.  Runtimes do that differently, and the difference is visible (<= 1 LSB on a
small fraction of values, compounding with depth).  Each runtime is a
``mnss_kit.ops.runtimes.Runtime``, plain data naming its rounding rules; these functions branch
on its fields only:

``q31`` (``tflite-ref``, ``tflite-builtin``)  The real multiplier becomes an int32 Q31
    mantissa and a power-of-two shift (``multiplier.quantize_multiplier``); the product is
    ``rounding_divide_by_pot(saturating_rounding_doubling_high_mul(x << left, m), right)``:
    two roundings, the high multiply's ties toward +infinity and the shift's ties away from
    zero (``tflite-ref``) or half up, ``(x + 2^(n-1)) >> n`` (``tflite-builtin``).
``float32`` (``xnnpack``, ``ort-cpu``)  float32 ``scale = s_in * s_w / s_out``,
    ``float32(acc) * scale`` rounded half to even, then zero point and clamp.

All integer arithmetic is carried out in int64 numpy arrays so intermediate products never
overflow; results are returned in the dtype the runtime stores.
"""

from __future__ import annotations

import numpy as np

from ..runtimes import Runtime, get_runtime
from .multiplier import effective_multiplier, multiply_by_quantized_multiplier, quantize_multiplier
from .quantize import dequantize, quantize
from .ranges import QParams, _clamp_int8, qrange
from .rounding import round_float
from .vector import _by_position, vector_width


def requantize(
    acc: np.ndarray,
    input_scale: float,
    weight_scales: np.ndarray,
    output_scale: float,
    output_zero_point: int,
    runtime: str | Runtime,
    dtype: str = "int8",
    clamp: tuple[int, int] | None = None,
) -> np.ndarray:
    """int32 accumulator ``(..., C)`` (channels last) -> ``dtype`` output of CONV_2D / DEPTHWISE_CONV_2D.

    ``acc = sum((x_q - x_zp) * w_q) + bias_q`` (int32, exact).  ``weight_scales``
    is (C,) or scalar.  ``clamp`` are the fused-activation bounds in the output
    integer domain (default: the dtype's range).
    """
    p = get_runtime(runtime)
    acc = np.asarray(acc, dtype=np.int64)
    real = effective_multiplier(input_scale, weight_scales, output_scale, p)
    if p.multiplier == "q31":
        pairs = [quantize_multiplier(float(r)) for r in real]
        mult = np.array([m for m, _ in pairs], dtype=np.int64)
        shift = np.array([s for _, s in pairs], dtype=np.int64)
        scaled = multiply_by_quantized_multiplier(acc, mult, shift, p.shift_rounding)
    else:
        product = acc.astype(np.float32) * real  # float32(acc): exact only below 2^24, as in the runtime
        scaled = round_float(product.astype(np.float32), p.float_rounding)
    lo, hi = clamp if clamp is not None else qrange(dtype)
    return np.clip(scaled + output_zero_point, lo, hi).astype(dtype)


def activation_bounds(activation: str, scale: float, zero_point: int, dtype: str = "int8") -> tuple[int, int]:
    """Integer clamp bounds of a fused activation (``none``, ``relu``, ``relu6``, ``relu_n1_to_1``).

    As TFLite ``CalculateActivationRangeQuantized``: real bounds quantized with
    ties away from zero, intersected with the dtype's range.
    """
    qmin, qmax = qrange(dtype)
    real = {"none": (None, None), "relu": (0.0, None), "relu6": (0.0, 6.0), "relu_n1_to_1": (-1.0, 1.0)}[activation]

    def q(v):
        return int(zero_point + round_float(np.float32(v) / np.float32(scale), "away_from_zero"))

    lo = qmin if real[0] is None else max(qmin, q(real[0]))
    hi = qmax if real[1] is None else min(qmax, q(real[1]))
    return lo, hi


# ---------------------------------------------------------------------------
# QUANTIZE int8 -> int8


XNNPACK_CONVERT_RANGE = (2.0**-8, 2.0**7)  # s_in / s_out ratios XNNPACK accepts for an int8 -> int8 QUANTIZE


def requantize_int8(x: np.ndarray, x_q: QParams, out_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """QUANTIZE int8 -> int8 (new scale and zero point) by the runtime's ``requantize`` formula.

    ``scalar``: ``requantize`` of ``x - z_in`` under the runtime with a unit weight scale
    (Q31 multiplier of ``s_in / s_out`` from float64 of the float32 scales; the final shift
    rounds ties away from zero or up).  ``tflite_neon16`` (LiteRT optimized): full blocks of 16
    (flattened) ``scalar`` under ``tflite-builtin``, the tail under ``tflite-ref``.
    ``xnnpack_q8``: XNNPACK ``convert``: ``m = rint(256 * float32(s_in / s_out))``,
    ``((x - z_in) * m + 128) >> 8``, plus ``z_out``; outside ``XNNPACK_CONVERT_RANGE`` XNNPACK
    declines the op and LiteRT's optimized kernel runs it (``tflite_neon16``).  ``onnxruntime``
    (a DequantizeLinear -> QuantizeLinear pair): ``quantize.quantize`` under ``ort-cpu`` of
    ``quantize.dequantize``.
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
        return quantize(dequantize(x, si, zi), so, zo, "int8", "ort-cpu")
    if formula == "xnnpack_q8":
        m = int(np.rint(np.float32(256.0) * ratio))
        d = np.asarray(x, dtype=np.int64) - zi
        return _clamp_int8(((d * m + 128) >> 8) + zo, None)
    return _requantize_scalar(x, x_q, out_q, runtime)


def _requantize_scalar(x: np.ndarray, x_q: QParams, out_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """int8 -> int8 as a unit-weight ``requantize`` under the runtime's CONV_2D rule."""
    d = np.asarray(x, dtype=np.int64) - x_q[1]
    return requantize(d, x_q[0], np.float32(1.0), out_q[0], out_q[1], runtime)
