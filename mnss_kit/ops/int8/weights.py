"""Weights and bias of CONV_2D / DEPTHWISE_CONV_2D: symmetric int8 weights in [-127, 127] with one
scale per output channel; an int32 bias with scale ``input_scale * weight_scale[c]`` and zero point 0.
"""

from __future__ import annotations

import numpy as np

from .ranges import INT32_MAX, INT32_MIN, WEIGHT_MAX
from .rounding import round_float


def quantize_weights_per_channel(w: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric int8 weights with one scale per channel along ``axis``.

    ``scale[c] = max|w[c]| / 127`` (float32; an all-zero channel gets scale 1),
    ``q = clamp(round(w / scale), -127, 127)`` with ties away from zero.
    Returns ``(q int8 same shape as w, scales float32 (C,))``.
    """
    w = np.asarray(w, dtype=np.float32)
    other = tuple(i for i in range(w.ndim) if i != axis % w.ndim)
    bound = np.max(np.abs(w), axis=other) if other else np.abs(w)
    scales = np.where(bound > 0, bound / np.float32(WEIGHT_MAX), np.float32(1.0)).astype(np.float32)
    return quantize_weights_with_scales(w, scales, axis), scales


def quantize_weights_with_scales(w: np.ndarray, scales: np.ndarray, axis: int) -> np.ndarray:
    """``clamp(round(w / scale[c]), -127, 127)`` as int8 for given per-channel float32 ``scales``."""
    w = np.asarray(w, dtype=np.float32)
    shape = [1] * w.ndim
    shape[axis] = -1
    scaled = w / np.asarray(scales, dtype=np.float32).reshape(shape)
    return np.clip(round_float(scaled, "away_from_zero"), -WEIGHT_MAX, WEIGHT_MAX).astype(np.int8)


def bias_scales(input_scale: float, weight_scales: np.ndarray) -> np.ndarray:
    """Bias scale per channel, ``float32(s_in * s_w[c])`` (float32, shape (C,))."""
    return (np.float32(input_scale) * np.asarray(weight_scales, dtype=np.float32)).astype(np.float32)


def quantize_bias(bias: np.ndarray, input_scale: float, weight_scales: np.ndarray) -> np.ndarray:
    """int32 bias ``round(b / (s_in * s_w[c]))`` (ties away from zero), zero point 0.

    Raises ``ValueError`` if a value does not fit int32 (the caller should
    raise that channel's weight scale).  Returns int32 (C,).
    """
    scale = bias_scales(input_scale, weight_scales).astype(np.float64)
    q = round_float(np.asarray(bias, dtype=np.float64) / scale, "away_from_zero")
    if np.any(q > INT32_MAX) or np.any(q < INT32_MIN):
        raise ValueError("bias does not fit int32 at this input and weight scale")
    return q.astype(np.int32)
