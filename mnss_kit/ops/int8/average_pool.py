"""int8 AVERAGE_POOL_2D: the integer average of LiteRT (padding not counted), and ONNX Runtime's,
which on x86-64 runs a QDQ AveragePool as a float kernel (dequantize, float32 window sum in
order, divide, quantize), reproduced here operation by operation.
"""

from __future__ import annotations

import numpy as np

from ..runtimes import check_formula
from .quantize import dequantize
from .ranges import QParams, _clamp_int8
from .rounding import _trunc_div


def average_pool_round(total: np.ndarray, count: int) -> np.ndarray:
    """Integer average of a window sum, ties away from zero (TFLite reference AVERAGE_POOL_2D)."""
    total = np.asarray(total, dtype=np.int64)
    half = count // 2
    return np.where(total > 0, _trunc_div(total + half, count), _trunc_div(total - half, count))


def average_pool_divide(total: np.ndarray, count: np.ndarray, formula: str) -> np.ndarray:
    """Window sum of raw int8 values / number of valid inputs (int64 arrays, broadcastable) -> int64.

    ``tflite`` (every LiteRT runtime; XNNPACK does not take int8 AVERAGE_POOL_2D):
    ``average_pool_round``, ties away from zero.  The ``onnxruntime`` formula does not
    start from the integer sum: see :func:`average_pool_float`.
    """
    check_formula("AVERAGE_POOL_2D", formula)
    if formula != "tflite":
        raise ValueError(f"AVERAGE_POOL_2D formula {formula!r} needs the float window sums (average_pool_float)")
    return average_pool_round(total, np.asarray(count, dtype=np.int64))


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
    values = dequantize(x, s, zp)
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
