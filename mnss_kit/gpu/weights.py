"""Learned 3x3 convs of a GPU stage, packed for ``conv3x3.glsl`` (no torch: numpy arrays)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UserError


def layers_of(channels: int) -> int:
    """Number of four-channel texture layers that hold ``channels`` channels."""
    return -(-channels // 4)


def pack_conv3x3(weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """``(Cout, Cin, 3, 3)`` weights and ``(Cout,)`` bias -> ``(n, 4)`` float32, the conv3x3.glsl layout.

    Rows ``[0, out_layers)``: biases of output channels ``4og .. 4og+3``.  Row
    ``out_layers + ((og * 9 + tap) * in_layers + il) * 4 + k`` (``tap = 3 ky + kx``): the
    weights from input channel ``4il + k`` to output channels ``4og .. 4og+3``.  Missing
    channels are zero.
    """
    w = np.asarray(weight, dtype=np.float32)
    cout, cin = w.shape[:2]
    if w.shape[2:] != (3, 3):
        raise ValueError(f"expected a 3x3 kernel, got {w.shape}")
    out_layers, in_layers = layers_of(cout), layers_of(cin)
    padded = np.zeros((out_layers * 4, in_layers * 4, 3, 3), dtype=np.float32)
    padded[:cout, :cin] = w
    b = np.zeros(out_layers * 4, dtype=np.float32)
    b[:cout] = np.asarray(bias, dtype=np.float32)
    # (og, o4, il, k, ky, kx) -> (og, ky, kx, il, k, o4)
    blocks = padded.reshape(out_layers, 4, in_layers, 4, 3, 3).transpose(0, 4, 5, 2, 3, 1)
    return np.concatenate([b.reshape(out_layers, 4), blocks.reshape(-1, 4)], axis=0)


@dataclass(frozen=True)
class Conv3x3:
    """One 3x3 conv with bias: ``weight`` ``(Cout, Cin, 3, 3)`` and ``bias`` ``(Cout,)`` float32."""

    weight: np.ndarray
    bias: np.ndarray

    @property
    def in_channels(self) -> int:
        return int(self.weight.shape[1])

    @property
    def out_channels(self) -> int:
        return int(self.weight.shape[0])

    def packed(self) -> np.ndarray:
        return pack_conv3x3(self.weight, self.bias)
