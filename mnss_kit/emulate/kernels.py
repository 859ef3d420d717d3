"""Integer-exact numpy kernels of the desktop NPU emulator (int8, NHWC).

Each kernel reproduces one LiteRT / XNNPACK / ONNX Runtime kernel bit for
bit under a named runtime (``runtime``; see ``mnss_kit.ops.runtimes``).  The
arithmetic that differs between runtimes (requantization, ADD, MUL,
QUANTIZE, tables) is defined once in ``mnss_kit.ops.int8``, one module
per op; this module adds the data movement (im2col,
windows, padding) and picks the formula the runtime names.

Conventions: activations are ``(N, H, W, C)`` int8 with per-tensor
``(scale, zero_point)`` pairs (``QParams``); CONV_2D weights are OHWI and
DEPTHWISE_CONV_2D weights 1HWO, symmetric int8 with one float32 scale per
output channel; biases are int32 with scale ``s_in * s_w[c]``.  Scales are
float32, as stored in a ``.tflite`` file.

Exactness of the fast convolution: the products are formed by a float
matrix multiply of integer-valued operands.  ``|x - x_zp| <= 255`` and
``|w| <= 128``, so a dot product of length K is bounded by ``K * 32640``;
float32 sums of integers are exact below 2^24 (K <= 514) and float64 below
2^53, whatever the summation order.  ``_dot_dtype`` picks float32 when the
bound allows it and float64 otherwise.
"""

from __future__ import annotations

import numpy as np

from mnss_kit.ops.int8 import average_pool, logistic_tanh, vector
from mnss_kit.ops.int8 import mul as int8_mul
from mnss_kit.ops.int8 import requantize as int8_requantize
from mnss_kit.ops.int8 import resize_bilinear as int8_resize
from mnss_kit.ops.runtimes import Runtime, get_runtime

QParams = tuple[float, int]  # (scale, zero_point) of a per-tensor quantized tensor

_MAX_TERM = 255 * 128  # largest |(x - x_zp) * w| for int8 operands
_IM2COL_BUDGET = 1 << 22  # elements of one im2col chunk (bounds memory)


def _dot_dtype(k: int) -> type:
    """float32 if every partial sum of ``k`` int8 products is an exact float32 integer, else float64."""
    return np.float32 if k * _MAX_TERM < 2**24 else np.float64


def output_size(size: int, kernel: int, stride: int, padding: str) -> tuple[int, int]:
    """Output length and leading pad of one spatial axis (TFLite ``ComputePaddingHeightWidth``, dilation 1)."""
    if padding == "SAME":
        out = -(-size // stride)
        total = max((out - 1) * stride + kernel - size, 0)
        return out, total // 2
    if padding == "VALID":
        if size < kernel:
            raise ValueError(f"VALID window {kernel} larger than input {size}")
        return (size - kernel) // stride + 1, 0
    raise ValueError(f"padding must be SAME or VALID, not {padding!r}")


def _centred_padded(x: np.ndarray, zero_point: int, kernel: tuple[int, int], stride: int, padding: str, dtype) -> tuple[np.ndarray, int, int]:
    """``x - zero_point`` in ``dtype``, zero padded for the window; returns it and the output size."""
    n, h, w, c = x.shape
    ho, top = output_size(h, kernel[0], stride, padding)
    wo, left = output_size(w, kernel[1], stride, padding)
    hp = max((ho - 1) * stride + kernel[0], h + top)
    wp = max((wo - 1) * stride + kernel[1], w + left)
    padded = np.zeros((n, hp, wp, c), dtype=dtype)
    padded[:, top:top + h, left:left + w] = x.astype(dtype) - dtype(zero_point)
    return padded, ho, wo


def conv_accumulators(x: np.ndarray, x_zero_point: int, weights: np.ndarray, bias: np.ndarray | None,
                      stride: int = 1, padding: str = "SAME") -> np.ndarray:
    """Exact CONV_2D accumulators ``sum((x - x_zp) * w) + bias``.

    ``x`` (N, H, W, Ci) int8, ``weights`` (Co, KH, KW, Ci) int8, ``bias`` (Co,)
    int32 or None.  Returns (N, Ho, Wo, Co) int64.  im2col over chunks of
    output rows, products by a float matmul that is exact (module docstring).
    """
    co, kh, kw, ci = weights.shape
    if x.shape[-1] != ci:
        raise ValueError(f"input has {x.shape[-1]} channels, weights expect {ci}")
    k = kh * kw * ci
    dot = _dot_dtype(k)
    padded, ho, wo = _centred_padded(x, x_zero_point, (kh, kw), stride, padding, dot)
    n = x.shape[0]
    w_mat = weights.reshape(co, k).T.astype(dot)  # (K, Co), K ordered (ky, kx, ci)
    acc = np.empty((n, ho, wo, co), dtype=np.int64)
    rows = max(1, _IM2COL_BUDGET // max(1, n * wo * k))
    for y0 in range(0, ho, rows):
        y1 = min(ho, y0 + rows)
        cols = np.empty((n, y1 - y0, wo, kh, kw, ci), dtype=dot)
        for i in range(kh):
            for j in range(kw):
                cols[:, :, :, i, j] = padded[:, y0 * stride + i:(y1 - 1) * stride + i + 1:stride,
                                             j:j + (wo - 1) * stride + 1:stride]
        acc[:, y0:y1] = (cols.reshape(-1, k) @ w_mat).reshape(n, y1 - y0, wo, co)
    if bias is not None:
        acc += np.asarray(bias, dtype=np.int64)
    return acc


def depthwise_accumulators(x: np.ndarray, x_zero_point: int, weights: np.ndarray, bias: np.ndarray | None,
                           stride: int = 1, padding: str = "SAME") -> np.ndarray:
    """Exact DEPTHWISE_CONV_2D accumulators; ``weights`` (1, KH, KW, Ci*M) int8, output channel ``o`` reads input ``o // M``.

    ``x`` (N, H, W, Ci) int8; returns (N, Ho, Wo, Ci*M) int64.
    """
    _, kh, kw, co = weights.shape
    ci = x.shape[-1]
    if co % ci:
        raise ValueError(f"depthwise output channels {co} are not a multiple of input channels {ci}")
    padded, ho, wo = _centred_padded(x, x_zero_point, (kh, kw), stride, padding, np.int32)
    padded = np.repeat(padded, co // ci, axis=-1)  # channel o reads input o // M
    acc = np.zeros((x.shape[0], ho, wo, co), dtype=np.int32)  # |acc| <= KH*KW*32640 fits int32 for KH*KW < 65000
    w32 = weights[0].astype(np.int32)
    for i in range(kh):
        for j in range(kw):
            acc += padded[:, i:i + (ho - 1) * stride + 1:stride, j:j + (wo - 1) * stride + 1:stride] * w32[i, j]
    acc = acc.astype(np.int64)
    if bias is not None:
        acc += np.asarray(bias, dtype=np.int64)
    return acc


def _requantize(acc: np.ndarray, x_q: QParams, w_scales: np.ndarray, out_q: QParams, activation: str,
                runtime: Runtime) -> np.ndarray:
    clamp = int8_requantize.activation_bounds(activation, out_q[0], out_q[1])
    return int8_requantize.requantize(acc, x_q[0], w_scales, out_q[0], out_q[1], runtime, clamp=clamp)


def conv2d(x: np.ndarray, x_q: QParams, weights: np.ndarray, w_scales: np.ndarray, bias: np.ndarray | None,
           out_q: QParams, stride: int = 1, padding: str = "SAME", activation: str = "none",
           runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """CONV_2D: (N, H, W, Ci) int8 x (Co, KH, KW, Ci) int8 -> (N, Ho, Wo, Co) int8.

    ``w_scales`` (Co,) float32, ``bias`` (Co,) int32, ``activation`` one of
    ``none``/``relu``/``relu6``/``relu_n1_to_1`` (a clamp in the output domain).
    """
    rt = get_runtime(runtime)
    acc = conv_accumulators(x, x_q[1], weights, bias, stride, padding)
    return _requantize(acc, x_q, w_scales, out_q, activation, rt)


def depthwise_conv2d(x: np.ndarray, x_q: QParams, weights: np.ndarray, w_scales: np.ndarray, bias: np.ndarray | None,
                     out_q: QParams, stride: int = 1, padding: str = "SAME", activation: str = "none",
                     runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """DEPTHWISE_CONV_2D: (N, H, W, Ci) int8 x (1, KH, KW, Co) int8 -> (N, Ho, Wo, Co) int8; Co = Ci * multiplier."""
    rt = get_runtime(runtime)
    acc = depthwise_accumulators(x, x_q[1], weights, bias, stride, padding)
    w_scales = np.broadcast_to(np.asarray(w_scales, dtype=np.float32), acc.shape[-1:])
    width = rt.depthwise_vector_channels
    body = acc.shape[-1] // width * width if width else acc.shape[-1]
    out = np.empty(acc.shape, dtype=np.int8)
    out[..., :body] = _requantize(acc[..., :body], x_q, w_scales[:body], out_q, activation, rt)
    out[..., body:] = _requantize(acc[..., body:], x_q, w_scales[body:], out_q, activation, get_runtime(rt.depthwise_tail))
    return out


def add(a: np.ndarray, a_q: QParams, b: np.ndarray, b_q: QParams, out_q: QParams, activation: str = "none",
        runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """ADD of two int8 tensors of one shape -> int8 (LiteRT's broadcasting paths are not modelled)."""
    rt = get_runtime(runtime)
    clamp = int8_requantize.activation_bounds(activation, out_q[0], out_q[1])
    return vector.add(a, a_q, b, b_q, out_q, rt.add, clamp=clamp)


def mul(a: np.ndarray, a_q: QParams, b: np.ndarray, b_q: QParams, out_q: QParams, activation: str = "none",
        runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """MUL of two int8 tensors of one shape -> int8."""
    rt = get_runtime(runtime)
    clamp = int8_requantize.activation_bounds(activation, out_q[0], out_q[1])
    return int8_mul.mul(a, a_q, b, b_q, out_q, rt.mul, clamp=clamp)


def concatenation(tensors: list[np.ndarray], axis: int = -1) -> np.ndarray:
    """CONCATENATION of int8 tensors sharing one scale and zero point (no arithmetic)."""
    return np.concatenate(tensors, axis=axis)


def logistic(x: np.ndarray, x_q: QParams, runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """LOGISTIC: int8 -> int8 with the fixed output params (1/256, -128)."""
    rt = get_runtime(runtime)
    return logistic_tanh.logistic(x, x_q, rt)


def tanh(x: np.ndarray, x_q: QParams, runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """TANH: int8 -> int8 with the fixed output params (1/128, 0)."""
    rt = get_runtime(runtime)
    return logistic_tanh.tanh(x, x_q, rt)


def average_pool2d(x: np.ndarray, size: int, stride: int, padding: str = "VALID", activation: str = "none",
                   out_q: QParams | None = None, runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """AVERAGE_POOL_2D (input and output share params): (N, H, W, C) int8 -> (N, Ho, Wo, C) int8.

    Padded positions are not counted (the divisor is the number of valid
    inputs under the window).  ``out_q`` is needed only for a fused activation.
    """
    rt = get_runtime(runtime)
    n, h, w, c = x.shape
    ho, top = output_size(h, size, stride, padding)
    wo, left = output_size(w, size, stride, padding)
    total = np.zeros((n, ho, wo, c), dtype=np.int64)
    count = np.zeros((ho, wo), dtype=np.int64)
    ys = np.arange(ho) * stride - top
    xs = np.arange(wo) * stride - left
    xi = x.astype(np.int64)
    for i in range(size):
        yy = ys + i
        vy = (yy >= 0) & (yy < h)
        for j in range(size):
            xx = xs + j
            vx = (xx >= 0) & (xx < w)
            valid = vy[:, None] & vx[None, :]
            tap = xi[:, np.clip(yy, 0, h - 1)][:, :, np.clip(xx, 0, w - 1)]
            total += np.where(valid[None, :, :, None], tap, 0)
            count += valid
    avg = average_pool.average_pool_divide(total, count[None, :, :, None], rt.average_pool)
    lo, hi = int8_requantize.activation_bounds(activation, *out_q) if out_q is not None else (-128, 127)
    return np.clip(avg, lo, hi).astype(np.int8)


def resize_bilinear(x: np.ndarray, out_hw: tuple[int, int], half_pixel_centers: bool = True,
                    runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """RESIZE_BILINEAR (align_corners False): (N, H, W, C) int8 -> (N, Ho, Wo, C) int8, params kept."""
    rt = get_runtime(runtime)
    return int8_resize.resize_bilinear(x, out_hw, half_pixel_centers, rt.resize_bilinear)


def depth_to_space(x: np.ndarray, block: int) -> np.ndarray:
    """DEPTH_TO_SPACE: (N, H, W, C*b*b) -> (N, H*b, W*b, C); input channel order (dy, dx, c)."""
    n, h, w, c = x.shape
    if c % (block * block):
        raise ValueError(f"{c} channels are not divisible by block {block} squared")
    oc = c // (block * block)
    return x.reshape(n, h, w, block, block, oc).transpose(0, 1, 3, 2, 4, 5).reshape(n, h * block, w * block, oc)


def space_to_depth(x: np.ndarray, block: int) -> np.ndarray:
    """SPACE_TO_DEPTH: (N, H*b, W*b, C) -> (N, H, W, C*b*b); output channel order (dy, dx, c)."""
    n, h, w, c = x.shape
    if h % block or w % block:
        raise ValueError(f"spatial size {(h, w)} is not divisible by block {block}")
    y = x.reshape(n, h // block, block, w // block, block, c).transpose(0, 1, 3, 2, 4, 5)
    return y.reshape(n, h // block, w // block, block * block * c)


def pad(x: np.ndarray, paddings: np.ndarray, zero_point: int) -> np.ndarray:
    """PAD: ``paddings`` (4, 2) int (before, after) per axis; fills the zero point (real 0)."""
    return np.pad(x, np.asarray(paddings, dtype=np.int64), constant_values=np.int8(zero_point))


def quantize(x: np.ndarray, out_q: QParams, runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """QUANTIZE float32 -> int8."""
    return vector.quantize(x, out_q, runtime)


def requantize(x: np.ndarray, x_q: QParams, out_q: QParams, runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """QUANTIZE int8 -> int8 (a change of scale and zero point)."""
    return int8_requantize.requantize_int8(x, x_q, out_q, runtime)


def dequantize(x: np.ndarray, x_q: QParams, runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """DEQUANTIZE int8 -> float32."""
    return vector.dequantize(x, x_q, get_runtime(runtime).dequantize)
