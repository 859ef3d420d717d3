"""Affine quantization of a tensor: its parameters and the QUANTIZE / DEQUANTIZE formulas.

A real value ``r`` maps to an integer ``q`` with ``r = scale * (q - zero_point)``.  Activations
are per-tensor asymmetric int8 (or symmetric int16, zero point 0).  :func:`quantize` reads the
runtime's rounding fields; how LiteRT's optimized kernel rounds the tail of a tensor differently
is ``vector.quantize`` / ``vector.dequantize``.
"""

from __future__ import annotations

import numpy as np

from ..runtimes import Runtime, get_runtime
from .ranges import qrange
from .rounding import round_float


def choose_qparams(rmin: float, rmax: float, dtype: str = "int8", symmetric: bool = False) -> tuple[np.float32, int]:
    """Scale and zero point covering ``[rmin, rmax]`` (widened to include 0).

    Asymmetric (int8 activations): ``scale = (rmax - rmin) / 255`` and the zero
    point ``round(qmin - rmin / scale)`` (ties away from zero) clamped to the
    range, so real 0 is exactly representable.  Symmetric (int16 activations):
    ``scale = max(|rmin|, |rmax|) / qmax``, zero point 0.  A degenerate range
    gets scale 1 (values are then exactly 0).  Returns ``(float32 scale, int zp)``.
    """
    qmin, qmax = qrange(dtype)
    rmin, rmax = min(float(rmin), 0.0), max(float(rmax), 0.0)
    if symmetric:
        bound = max(-rmin, rmax)
        scale = np.float32(bound / qmax) if bound > 0 else np.float32(1.0)
        return scale, 0
    if rmax == rmin:
        return np.float32(1.0), 0
    scale = np.float32((rmax - rmin) / (qmax - qmin))
    zero_point = int(round_float(qmin - rmin / float(scale), "away_from_zero"))
    return scale, int(np.clip(zero_point, qmin, qmax))


def quantize(x: np.ndarray, scale: float, zero_point: int, dtype: str = "int8", runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """The QUANTIZE op: float32 ``x`` -> ``clamp(round(x / scale) + zero_point)`` in ``dtype``.

    The runtime fixes how ``x / scale`` is computed (true float32 division or
    multiplication by the float32 reciprocal) and how ties round.
    """
    p = get_runtime(runtime)
    x = np.asarray(x, dtype=np.float32)
    scale = np.float32(scale)
    if p.quantize_reciprocal:
        scaled = x * (np.float32(1.0) / scale)
    else:
        scaled = x / scale
    q = round_float(scaled.astype(np.float32), p.quantize_rounding) + zero_point
    qmin, qmax = qrange(dtype)
    return np.clip(q, qmin, qmax).astype(dtype)


def dequantize(q: np.ndarray, scale: float | np.ndarray, zero_point: int | np.ndarray = 0, axis: int | None = None) -> np.ndarray:
    """The DEQUANTIZE op: ``float32(scale * (q - zero_point))`` (correctly rounded float32 product).

    Per-channel parameters are given as arrays with ``axis`` naming the channel axis of ``q``.
    """
    q = np.asarray(q, dtype=np.int64)
    scale = np.asarray(scale, dtype=np.float32)
    zero_point = np.asarray(zero_point, dtype=np.int64)
    if axis is not None and scale.ndim == 1:
        shape = [1] * q.ndim
        shape[axis] = -1
        scale = scale.reshape(shape)
        zero_point = zero_point.reshape(shape) if zero_point.ndim == 1 else zero_point
    return ((q - zero_point).astype(np.float32) * scale).astype(np.float32)
