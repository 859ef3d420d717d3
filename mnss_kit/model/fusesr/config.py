"""The ``model:`` section of a FuseSR-family config."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from ...dataset.format import BUFFERS
from ...gpu.passes import PACKED_GBUFFERS

# HR G-buffers the H-Net can read, with their channels, in the order gbuffer_pack_pass concatenates them
GBUFFER_CHANNELS = {g: len(BUFFERS["hr"][g].channels) for g in PACKED_GBUFFERS}
SCALES = (2, 3, 4)


@dataclass
class FuseSRConfig:
    """Reduced FuseSR (Zhong et al. 2023): BRDF demodulation and HR G-buffer fusion at LR.

    ``variant: l`` is the paper's lightweight model: no history, half the channels,
    depthwise-separable convolutions.  ``history: true`` adds the previous output, warped and
    pixel-unshuffled, as an input (an MNSS x FuseSR hybrid; not with ``variant: l``).
    """

    family: Literal["fusesr"] = "fusesr"
    scale: int = 4
    variant: Literal["full", "l"] = "full"
    gbuffers: list[str] = field(default_factory=lambda: list(GBUFFER_CHANNELS))  # [] : no HR G-buffers
    demodulate: bool = True  # False: the net sees and predicts the display colour itself
    history: bool = False
    encoder_width: int = 16  # LR colour encoder features (the "l" variant halves every width)
    width: int = 32  # fusion backbone at LR
    layers: int = 3  # fusion backbone convs before the head, >= 1
    hr_channels: int = 8  # channels per HR pixel after the pixel shuffle, before the last conv

    def __post_init__(self):
        if self.scale not in SCALES:
            raise ValueError(f"scale must be one of {list(SCALES)}, got {self.scale}")
        unknown = [g for g in self.gbuffers if g not in GBUFFER_CHANNELS]
        if unknown:
            raise ValueError(f"unknown G-buffer '{unknown[0]}' (one of: {', '.join(GBUFFER_CHANNELS)})")
        if len(set(self.gbuffers)) != len(self.gbuffers):
            raise ValueError("gbuffers lists a buffer twice")
        if self.variant == "l" and self.history:
            raise ValueError("the 'l' variant has no history (use variant: full with history: true)")
        if self.layers < 1 or min(self.encoder_width, self.width, self.hr_channels) < 2:
            raise ValueError("layers must be >= 1 and encoder_width, width, hr_channels >= 2")

    @property
    def divisor(self) -> int:
        """Width divisor of the variant: the "l" variant halves every channel count."""
        return 2 if self.variant == "l" else 1

    @property
    def gbuffer_channels(self) -> int:
        """HR G-buffer channels, before the pixel unshuffle."""
        return sum(GBUFFER_CHANNELS[g] for g in self.ordered_gbuffers)

    @property
    def ordered_gbuffers(self) -> tuple[str, ...]:
        """The configured G-buffers in the fixed concatenation order of ``GBUFFER_CHANNELS``."""
        return tuple(g for g in GBUFFER_CHANNELS if g in self.gbuffers)

    def npu_input_channels(self) -> int:
        """Channels of the NPU input at LR: colour or L (3), warped history (3 s^2), G-buffers (C s^2)."""
        s2 = self.scale * self.scale
        return 3 + (3 * s2 if self.history else 0) + self.gbuffer_channels * s2
