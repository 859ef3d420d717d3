"""A faster numpy GPU stage with results identical to :class:`mnss_kit.gpu.reference.ReferencePasses`.

The reference 3x3 convolution (``ops.inpaint.conv3x3``) adds one tap and input channel at a time
to an ``(h, w, Cout)`` float32 accumulator, reading the channel as a strided ``(h, w, 1)`` view
of an interleaved image; at 640x360 the AA net spends most of its time on memory traffic.  Here
the input is planar ``(Cin, h, w)`` and the accumulator ``(Cout, rows, w)`` covers a block of
rows small enough to stay in cache while all taps are added.  Every output value still starts
at the bias and receives the same float32 products (rounded, then added: no fused multiply-add)
in the same order (taps row-major, channels in order), so the sums are bit-identical.  The
passes are the reference's with this convolution as their ``conv`` hook.
``tests/emulate/test_frame_loop_fast.py`` checks equality on every epilogue.
"""

from __future__ import annotations

import numpy as np

from ..gpu.reference import ReferencePasses

_BLOCK_VALUES = 1 << 17  # float32 accumulators per block (512 KB): product and sum stay in cache


def conv3x3_planar(image: np.ndarray, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """``ops.inpaint.conv3x3`` computed on planar blocks: ``(h, w, Cin)`` -> ``(h, w, Cout)`` float32, identical values."""
    x = np.asarray(image, dtype=np.float32)
    w = np.asarray(weight, dtype=np.float32)
    h, wd, cin = x.shape
    if w.shape[1:] != (cin, 3, 3):
        raise ValueError(f"weight {w.shape} does not fit a 3x3 conv on {cin} channels")
    cout = w.shape[0]
    planes = np.pad(np.moveaxis(x, -1, 0), ((0, 0), (1, 1), (1, 1)))  # (Cin, h+2, w+2), zero padding
    taps = [w[:, c, ky, kx][:, None, None].copy() for ky in range(3) for kx in range(3) for c in range(cin)]
    out = np.empty((h, wd, cout), dtype=np.float32)
    rows = max(1, _BLOCK_VALUES // (cout * wd))
    acc = np.empty((cout, rows, wd), dtype=np.float32)
    product = np.empty_like(acc)
    start = np.asarray(bias, dtype=np.float32)[:, None, None]
    for y0 in range(0, h, rows):
        n = min(rows, h - y0)
        a, p = acc[:, :n], product[:, :n]
        a[:] = start
        i = 0
        for ky in range(3):
            for kx in range(3):
                for c in range(cin):
                    np.multiply(planes[c, y0 + ky:y0 + ky + n, kx:kx + wd], taps[i], out=p)
                    a += p
                    i += 1
        out[y0:y0 + n] = np.moveaxis(a, 0, -1)
    return out


class FastReferencePasses(ReferencePasses):
    """``ReferencePasses`` with :func:`conv3x3_planar` as its convolution (same results)."""

    def __init__(self):
        super().__init__(conv=conv3x3_planar)
