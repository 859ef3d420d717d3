"""Learned weights of the GPU stage, read from a model state dict and packed for the shaders.

The GPU stage of MNSS has two learned parts: the inpainting conv (``inpaint.conv``, 4 -> 1
channels) and the anti-aliasing net (``aa.net``, 3x3 convs with ReLU between them).  No torch
here: the caller hands a state dict of numpy arrays (``{k: v.numpy() for k, v in
model.state_dict().items()}``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UserError
from ..model.config import aa_input_channels


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


@dataclass(frozen=True)
class GpuWeights:
    """``inpaint``: the inpainting conv, None without history; ``aa``: the AA net's convs in order."""

    inpaint: Conv3x3 | None
    aa: tuple[Conv3x3, ...]

    @property
    def aa_history_at_samples(self) -> bool:
        """The AA net reads I_R at the sampled sub-pixels too (``model.config.aa_input_channels``)."""
        return self.aa[0].in_channels == aa_input_channels(True)

    @classmethod
    def from_state_dict(cls, state: dict[str, np.ndarray]) -> "GpuWeights":
        """From an MNSS state dict (numpy values), keys ``inpaint.conv.*`` and ``aa.net.<i>.*``."""

        def conv(prefix: str) -> Conv3x3:
            try:
                weight, bias = state[prefix + ".weight"], state[prefix + ".bias"]
            except KeyError as e:
                raise UserError(f"model weights lack {e.args[0]}") from None
            return Conv3x3(np.asarray(weight, np.float32), np.asarray(bias, np.float32))

        inpaint = conv("inpaint.conv") if "inpaint.conv.weight" in state else None
        indices = sorted({int(k.split(".")[2]) for k in state if k.startswith("aa.net.") and k.endswith(".weight")})
        if not indices:
            raise UserError("model weights lack the anti-aliasing net (aa.net.*)")
        aa = tuple(conv(f"aa.net.{i}") for i in indices)
        for first, second in zip(aa, aa[1:]):
            if first.out_channels != second.in_channels:
                raise UserError("anti-aliasing net layers do not chain (channel counts differ)")
        paper, with_samples = aa_input_channels(False), aa_input_channels(True)
        if aa[0].in_channels not in (paper, with_samples) or aa[-1].out_channels != 3:
            raise UserError(f"anti-aliasing net must map {paper} channels (pooled history, colour) or {with_samples} "
                            "(pooled history, history at the samples, colour) to 3")
        return cls(inpaint, aa)
