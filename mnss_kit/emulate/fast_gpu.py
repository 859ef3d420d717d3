"""A faster numpy GPU stage with results identical to :class:`mnss_kit.gpu.reference.ReferencePasses`.

The reference 3x3 convolution (``ops.inpaint.conv3x3``) adds one tap and input channel at a time
to an ``(h, w, Cout)`` float32 accumulator, reading the channel as a strided ``(h, w, 1)`` view
of an interleaved image; at 640x360 the AA net spends seconds on cache misses.  Here the input is
planar ``(Cin, h, w)`` and the accumulator ``(Cout, h, w)``: every output value still starts at
the bias and receives the same float32 products in the same order (taps row-major, channels in
order), so the sums are bit-identical, about 2.5x faster.  Everything else is the reference's.
``tests/emulate/test_frame_loop_fast.py`` checks equality on every epilogue.
"""

from __future__ import annotations

import numpy as np

from ..gpu.reference import ReferencePasses, to_half
from ..gpu.weights import Conv3x3


def conv3x3_planar(image: np.ndarray, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """``ops.inpaint.conv3x3`` computed on planar buffers: ``(h, w, Cin)`` -> ``(h, w, Cout)`` float32, identical values."""
    x = np.asarray(image, dtype=np.float32)
    w = np.asarray(weight, dtype=np.float32)
    h, wd, cin = x.shape
    if w.shape[1:] != (cin, 3, 3):
        raise ValueError(f"weight {w.shape} does not fit a 3x3 conv on {cin} channels")
    planes = np.pad(np.moveaxis(x, -1, 0), ((0, 0), (1, 1), (1, 1)))  # (Cin, h+2, w+2), zero padding
    acc = np.empty((w.shape[0], h, wd), dtype=np.float32)
    acc[:] = np.asarray(bias, dtype=np.float32)[:, None, None]
    product = np.empty_like(acc)
    for ky in range(3):
        for kx in range(3):
            for c in range(cin):
                np.multiply(planes[c, ky:ky + h, kx:kx + wd], w[:, c, ky, kx][:, None, None], out=product)
                acc += product
    return np.ascontiguousarray(np.moveaxis(acc, 0, -1))


class FastReferencePasses(ReferencePasses):
    """``ReferencePasses`` with :func:`conv3x3_planar` in the conv3x3 pass (same results)."""

    def conv3x3(self, x, conv: Conv3x3, epilogue: str, residual=None):
        acc = conv3x3_planar(to_half(x), conv.weight, conv.bias)
        if epilogue == "relu":
            acc = np.maximum(acc, np.float32(0))
        elif epilogue == "residual_clamp":
            acc = np.clip(to_half(residual) + acc, np.float32(0), np.float32(1))
        elif epilogue != "none":
            return super().conv3x3(x, conv, epilogue, residual)  # the reference's message for an unknown epilogue
        return to_half(acc)
