"""The ``model:`` section of an MNSS-family config."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ...gpu.passes import avgpool_channels


def aa_input_channels(history_at_samples: bool) -> int:
    """Input channels of the anti-aliasing net: what ``avgpool_pass`` writes (``gpu.passes``).
    The torch model, the GPU passes and the bundle follow that layout."""
    return avgpool_channels(history_at_samples)


@dataclass
class MNSSConfig:
    """MNSS (Yang et al. 2023) with the knobs the config ladder and the ablations turn."""

    family: Literal["mnss"] = "mnss"
    scale: int = 2
    # what the next frame reuses: the model's output (paper), the previous LR frame upsampled, nothing
    history: Literal["output", "lr_frame", "none"] = "output"
    # lr: convolutions run on the pixel-unshuffled HR input (FuseSR trick); hr: every conv at HR (paper)
    recon_resolution: Literal["lr", "hr"] = "lr"
    recon_width: int = 32
    recon_layers: int = 4  # conv layers, >= 2
    aa_width: int = 16
    aa_layers: int = 3  # conv layers, >= 1
    # the AA net also sees I_R at the sub-pixels I_AA replaces (not in the paper; docs/architecture.md)
    aa_history_at_samples: bool = False
    inpaint_activation: Literal["sigmoid", "tanh"] = "sigmoid"  # tanh is clipped to [0, 1]
    # LR weights -> HR weight map: tile replication, or bilinear at the jittered sample positions
    weight_upsample: Literal["nearest", "bilinear"] = "bilinear"
    enhance: bool = False  # unsharp kernel on the displayed output (never on the history)
    enhance_beta: float = 0.15

    def __post_init__(self):
        if self.scale < 2:
            raise ValueError(f"scale must be >= 2, got {self.scale}")
        if self.recon_layers < 2 or self.aa_layers < 1:
            raise ValueError("recon_layers must be >= 2 and aa_layers >= 1")
        if min(self.recon_width, self.aa_width) < 1:
            raise ValueError("recon_width and aa_width must be >= 1")
        if not 0.0 <= self.enhance_beta <= 1.0:
            raise ValueError(f"enhance_beta must be in [0, 1], got {self.enhance_beta}")
