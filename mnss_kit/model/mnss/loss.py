"""The MNSS training loss (Yang et al. 2023), per frame::

    L = (1 - SSIM_11x11(I_SS, I_GT)) + w * perceptual(I_SS, I_GT) + k * mean|I_AA - I_GT[sampled]|
        + f * flicker

The perceptual term is ``model.losses.pyramid_loss`` (a weight-free stand-in for VGG features)
and the flicker term ``model.losses.flicker_term`` (off by default, f = 0; not in the paper).

``I_GT[sampled]`` is the HR reference at the HR pixels this frame's jittered
samples landed on (an LR-sized image), so the anti-aliasing net is taught to
produce exactly the values the reconstruction net inserts at those pixels.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ...metrics.image import ssim
from ..layers import avgpool, extract_samples
from ..losses import flicker_term, pyramid_loss


class MNSSLoss(nn.Module):
    """Per-frame loss; ``forward`` returns a dict of scalar tensors (``total`` plus each term)."""

    terms = ("total", "ssim", "perceptual", "aa", "flicker")  # the keys of ``forward``'s result, logged in this order

    def __init__(self, scale: int, perceptual_weight: float = 0.1, aa_weight: float = 5.0, flicker_weight: float = 0.0):
        super().__init__()
        self.scale = scale
        self.perceptual_weight = perceptual_weight
        self.aa_weight = aa_weight
        self.flicker_weight = flicker_weight

    def forward(self, output: torch.Tensor, aux: dict, frame: dict, reference: torch.Tensor,
                valid: torch.Tensor | None = None, flicker: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
        """``output``, ``reference`` (N, 3, H, W); ``aux`` the model's (``aa`` (N, 3, h, w) is used);
        ``frame`` the model's input (``jitter`` (N, 2) LR pixels is used); ``valid`` the (N, 1, H, W)
        crop-validity mask or None; ``flicker``: :meth:`flicker` of this frame, or None (the term is 0).

        Where ``valid`` is false the output was already replaced by the reference; the AA term
        takes the reference's samples there too."""
        aa, jitter = aux["aa"], frame["jitter"]
        if valid is not None:
            pooled = avgpool(valid.to(aa.dtype), self.scale)
            aa = torch.where(pooled > 0.999, aa, extract_samples(reference, jitter, self.scale))
        structural = 1.0 - ssim(output, reference).mean()
        perceptual = pyramid_loss(output, reference)
        aa_target = extract_samples(reference, jitter, self.scale)
        aa_term = F.l1_loss(aa, aa_target)
        flicker = output.new_zeros(()) if flicker is None else flicker
        total = structural + self.perceptual_weight * perceptual + self.aa_weight * aa_term + self.flicker_weight * flicker
        return {"total": total, "ssim": structural, "perceptual": perceptual, "aa": aa_term, "flicker": flicker}

    def flicker(self, error: torch.Tensor, prev_error: torch.Tensor, motion: torch.Tensor, reset: torch.Tensor | None) -> torch.Tensor:
        """``model.losses.flicker_term``."""
        return flicker_term(error, prev_error, motion, reset)
