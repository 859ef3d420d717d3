"""The FuseSR-family training loss, per frame, on the displayed output (as MNSS's)::

    L = (1 - SSIM_11x11(I, I_GT)) + w * perceptual(I, I_GT) + mean|I - I_GT| + f * flicker

The paper trains with an L1 and a perceptual term; SSIM is kept so the families share the
structural term the metrics report.  ``perceptual`` is ``model.losses.pyramid_loss``.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ...metrics.image import ssim
from ..losses import flicker_term, pyramid_loss


class FuseSRLoss(nn.Module):
    terms = ("total", "ssim", "perceptual", "l1", "flicker")

    def __init__(self, scale: int, perceptual_weight: float = 0.1, flicker_weight: float = 0.0):
        super().__init__()
        self.scale, self.perceptual_weight, self.flicker_weight = scale, perceptual_weight, flicker_weight

    def forward(self, output: torch.Tensor, aux: dict, frame: dict, reference: torch.Tensor,
                valid: torch.Tensor | None = None, flicker: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
        """``output``, ``reference`` (N, 3, H, W) display values; ``valid`` is unused (the output was
        already replaced by the reference where it is false); ``flicker`` as ``MNSSLoss``."""
        structural = 1.0 - ssim(output, reference).mean()
        perceptual = pyramid_loss(output, reference)
        l1 = F.l1_loss(output, reference)
        flicker = output.new_zeros(()) if flicker is None else flicker
        total = structural + self.perceptual_weight * perceptual + l1 + self.flicker_weight * flicker
        return {"total": total, "ssim": structural, "perceptual": perceptual, "l1": l1, "flicker": flicker}

    def flicker(self, error: torch.Tensor, prev_error: torch.Tensor, motion: torch.Tensor, reset: torch.Tensor | None) -> torch.Tensor:
        """``model.losses.flicker_term`` at this loss's scale."""
        return flicker_term(error, prev_error, motion, self.scale, reset)
