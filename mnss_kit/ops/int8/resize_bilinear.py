"""int8 RESIZE_BILINEAR (align_corners False) by the formula of each runtime: LiteRT's integer
kernel (1/1024 pixel), XNNPACK's Q11 lerp, and ONNX Runtime's, which on x86-64 runs a QDQ Resize
as dequantize, float32 bilinear resize, quantize, reproduced here operation by operation.
"""

from __future__ import annotations

import numpy as np

from ..runtimes import check_formula
from .quantize import dequantize, quantize
from .ranges import QParams


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


def _resize_tflite(x: np.ndarray, out_hw: tuple[int, int], half_pixel_centers: bool) -> np.ndarray:
    """LiteRT ``ResizeBilinearInteger``: four int64 weight products in 2^-20 units, rounded half away from zero."""
    y0, y1, fy = _tflite_source_10bit(out_hw[0], x.shape[1], half_pixel_centers)
    x0, x1, fx = _tflite_source_10bit(out_hw[1], x.shape[2], half_pixel_centers)
    v = np.asarray(x, dtype=np.int64)
    wy1, wy0 = fy[:, None, None], (1024 - fy)[:, None, None]
    wx1, wx0 = fx[None, :, None], (1024 - fx)[None, :, None]
    top = v[:, y0][:, :, x0] * wx0 + v[:, y0][:, :, x1] * wx1
    bottom = v[:, y1][:, :, x0] * wx0 + v[:, y1][:, :, x1] * wx1
    total = top * wy0 + bottom * wy1
    half = 1 << 19
    return np.where(total > 0, (total + half) >> 20, -((-total + half) >> 20)).astype(np.int8)


def _onnxruntime_source(out_size: int, in_size: int):
    """ONNX Runtime ``SetupUpsampleBilinear`` (half_pixel): taps and the float32 weights of the far and near tap."""
    scale = np.float32(np.float32(out_size) / np.float32(in_size))
    pos = ((np.arange(out_size, dtype=np.float32) + np.float32(0.5)) / scale).astype(np.float32) - np.float32(0.5)
    pos = np.clip(pos.astype(np.float32), np.float32(0), np.float32(in_size - 1))
    lower = np.minimum(pos.astype(np.int64), in_size - 1)
    upper = np.minimum(lower + 1, in_size - 1)
    d_lower = np.abs(pos - lower.astype(np.float32)).astype(np.float32)  # weight of the upper tap
    d_upper = np.abs(pos - upper.astype(np.float32)).astype(np.float32)  # weight of the lower tap
    same = lower == upper
    d_lower[same] = d_upper[same] = np.float32(0.5)
    return lower, upper, d_lower, d_upper


def _resize_onnxruntime(x: np.ndarray, out_hw: tuple[int, int], q: QParams) -> np.ndarray:
    """DequantizeLinear, float32 ``Resize`` (linear, half_pixel; ``dx2*dy2*X11 + dx1*dy2*X21 +
    dx2*dy1*X12 + dx1*dy1*X22`` left to right, each weight product rounded), QuantizeLinear."""
    y1, y2, dy1, dy2 = _onnxruntime_source(out_hw[0], x.shape[1])
    x1, x2, dx1, dx2 = _onnxruntime_source(out_hw[1], x.shape[2])
    v = dequantize(x, q[0], q[1])
    dx1, dx2 = dx1[None, None, :, None], dx2[None, None, :, None]
    dy1, dy2 = dy1[None, :, None, None], dy2[None, :, None, None]

    def term(wx, wy, rows, cols):
        return ((wx * wy).astype(np.float32) * v[:, rows][:, :, cols]).astype(np.float32)

    total = (term(dx2, dy2, y1, x1) + term(dx1, dy2, y1, x2)).astype(np.float32)
    total = (total + term(dx2, dy1, y2, x1)).astype(np.float32)
    total = (total + term(dx1, dy1, y2, x2)).astype(np.float32)
    return quantize(total, q[0], q[1], "int8", "ort-cpu")


def resize_bilinear(x: np.ndarray, out_hw: tuple[int, int], half_pixel_centers: bool, formula: str,
                    q: QParams | None = None) -> np.ndarray:
    """int8 RESIZE_BILINEAR (align_corners False), (N, H, W, C) -> (N, Ho, Wo, C); params unchanged.

    ``tflite``: LiteRT ``ResizeBilinearInteger``.  ``xnnpack_q11``: XNNPACK's Q11 lerp.
    ``onnxruntime`` (needs ``q``, the tensors' ``(scale, zero_point)``, and half-pixel
    centres): float32 resize between dequantize and quantize (:func:`_resize_onnxruntime`).
    """
    check_formula("RESIZE_BILINEAR", formula)
    if formula == "xnnpack_q11":
        return _resize_xnnpack(x, out_hw, half_pixel_centers)
    if formula == "tflite":
        return _resize_tflite(x, out_hw, half_pixel_centers)
    if q is None or not half_pixel_centers:
        raise ValueError("the onnxruntime RESIZE_BILINEAR formula needs the quantization params and half-pixel centres")
    return _resize_onnxruntime(x, out_hw, q)
