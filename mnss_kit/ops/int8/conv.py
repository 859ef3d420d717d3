"""CONV_2D / DEPTHWISE_CONV_2D integer accumulation (exact; slow reference).

The int32 accumulator ``sum((x_q - x_zp) * w_q) + bias_q`` is exact in every runtime; the output
stage that follows is ``requantize.requantize``.
"""

from __future__ import annotations

import numpy as np


def conv2d_accumulate(
    x: np.ndarray,
    x_zero_point: int,
    w: np.ndarray,
    bias: np.ndarray,
    stride: tuple[int, int] = (1, 1),
    padding: tuple[int, int, int, int] = (0, 0, 0, 0),
    dilation: tuple[int, int] = (1, 1),
    depthwise: bool = False,
) -> np.ndarray:
    """int32 accumulator of CONV_2D / DEPTHWISE_CONV_2D: ``sum((x - x_zp) * w) + bias``.

    ``x``: (N, H, W, Cin) integer.  ``w``: (Cout, KH, KW, Cin) int8 (OHWI) for a
    convolution, (1, KH, KW, C) for a depthwise one (multiplier 1).  ``bias``:
    (Cout,) int32.  ``padding`` = (top, bottom, left, right); padded positions
    hold the input zero point, i.e. contribute 0.  Returns int64 (N, OH, OW, Cout)
    holding the int32 accumulator (the runtimes assume no int32 overflow).
    """
    xs = np.asarray(x, dtype=np.int64) - x_zero_point
    top, bottom, left, right = padding
    xs = np.pad(xs, ((0, 0), (top, bottom), (left, right), (0, 0)))
    w = np.asarray(w, dtype=np.int64)
    _, kh, kw, _ = w.shape
    (sy, sx), (dy, dx) = stride, dilation
    oh = (xs.shape[1] - dy * (kh - 1) - 1) // sy + 1
    ow = (xs.shape[2] - dx * (kw - 1) - 1) // sx + 1
    cout = w.shape[3] if depthwise else w.shape[0]
    acc = np.zeros((xs.shape[0], oh, ow, cout), dtype=np.int64)
    for ky in range(kh):
        for kx in range(kw):
            y0, x0 = ky * dy, kx * dx
            patch = xs[:, y0 : y0 + sy * (oh - 1) + 1 : sy, x0 : x0 + sx * (ow - 1) + 1 : sx, :]
            if depthwise:
                acc += patch * w[0, ky, kx, :]
            else:
                acc += np.einsum("nhwc,oc->nhwo", patch, w[:, ky, kx, :])
    return acc + np.asarray(bias, dtype=np.int64)
