"""Loss terms shared by the model families: a weight-free perceptual stand-in and Charbonnier.

Perceptual term.  The MNSS paper uses VGG-19 features, which need ImageNet weights
that cannot be downloaded in every environment and that a toolkit should not
silently fetch.  ``pyramid_loss`` replaces it with a fixed, weight-free loss
that rewards the same things in super-resolution: the distance between the
Laplacian pyramids of the two images (each band-pass level compares edges and
texture at one scale; the final low-pass level keeps colours honest) plus the
distance of their horizontal and vertical finite differences (sharp,
correctly placed edges at full resolution), each measured with the
Charbonnier penalty (a smooth L1).  It is deterministic, costs a few
depthwise convolutions, and unlike a random-feature network its meaning does
not depend on a seed.

``flicker_term`` is the change of the error from the previous frame,
``charbonnier(e_t - warp(e_{t-1}))`` with ``e = output - reference``.  A per-frame loss
is blind to errors that are small but differ from frame to frame, which a static view shows as
flicker.  The term compares errors, not images, so a real change of the scene (and a
disocclusion, where both warped images are wrong alike) costs nothing by itself.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ..metrics.image import ssim
from .layers import warp_bilinear
from .taau import hr_motion_of

# Band-pass and gradient differences of flat regions are rounding noise around zero; a plain L1 turns
# that noise into full-size random gradient signs, the Charbonnier penalty (as in LapSRN) does not.
CHARBONNIER_EPS = 1e-3
# 5-tap binomial filter, the classic Burt-Adelson pyramid kernel
_BINOMIAL = torch.tensor([1.0, 4.0, 6.0, 4.0, 1.0]) / 16.0


def _blur(x: torch.Tensor) -> torch.Tensor:
    """Separable 5x5 binomial blur of (N, C, H, W), edge-replicating padding."""
    c = x.shape[1]
    k = _BINOMIAL.to(x)
    x = F.pad(x, (2, 2, 2, 2), mode="replicate")
    x = F.conv2d(x, k.view(1, 1, 1, 5).expand(c, 1, 1, 5), groups=c)
    return F.conv2d(x, k.view(1, 1, 5, 1).expand(c, 1, 5, 1), groups=c)


def laplacian_pyramid(x: torch.Tensor, levels: int) -> list[torch.Tensor]:
    """Band-pass levels of (N, C, H, W) finest first, then the low-pass residual (``levels + 1`` tensors)."""
    bands = []
    current = x
    for _ in range(levels):
        if min(current.shape[-2:]) < 4:
            break
        low = F.avg_pool2d(_blur(current), 2, ceil_mode=True)
        up = F.interpolate(low, size=current.shape[-2:], mode="bilinear", align_corners=False)
        bands.append(current - up)
        current = low
    bands.append(current)
    return bands


def charbonnier(x: torch.Tensor, eps: float = CHARBONNIER_EPS) -> torch.Tensor:
    """Mean of ``sqrt(x^2 + eps^2) - eps``: L1 away from zero, smooth at zero."""
    return (torch.sqrt(x * x + eps * eps) - eps).mean()


def pyramid_loss(output: torch.Tensor, target: torch.Tensor, levels: int = 3) -> torch.Tensor:
    """Perceptual stand-in: Laplacian-pyramid plus image-gradient distances (Charbonnier); (N, 3, H, W) -> scalar."""
    d = output - target  # the pyramid and the differences are linear: transform the difference once
    bands = laplacian_pyramid(d, levels)
    band = sum(charbonnier(b) for b in bands) / len(bands)
    grad = charbonnier(d[..., :, 1:] - d[..., :, :-1]) + charbonnier(d[..., 1:, :] - d[..., :-1, :])
    return band + grad


def flicker_term(error: torch.Tensor, prev_error: torch.Tensor, motion: torch.Tensor,
                 reset: torch.Tensor | None) -> torch.Tensor:
    """Change of the error ``e`` (N, 3, H, W) from the previous frame's, warped by the LR ``motion``
    (N, 2, h, w); frames with ``reset`` (N,) set have no previous frame.  The motion is brought to the
    error's size: the scale is the batch's (training on several scales), not fixed by the loss."""
    height, width = error.shape[-2:]
    hr_motion = hr_motion_of(motion, width / motion.shape[-1], (width, height))  # upsample_motion when tiled
    change = error - warp_bilinear(prev_error, hr_motion)
    if reset is not None:
        change = change * (reset <= 0.5).to(change.dtype).view(-1, 1, 1, 1)
    return charbonnier(change)


class DisplayLoss(nn.Module):
    """The loss of the families that train on the displayed output alone (fusesr, ntaau), per frame::

        L = (1 - SSIM_11x11(I, I_GT)) + w * perceptual(I, I_GT) + mean|I - I_GT| + m * mean (I - I_GT)^2
            + f * flicker

    The squared term weighs an error by its size, so it pulls hardest on the few large errors (edges)
    that L1 and SSIM weigh like any other; it is the error PSNR reports.
    """

    terms = ("total", "ssim", "perceptual", "l1", "mse", "flicker")

    def __init__(self, scale: int, perceptual_weight: float = 0.1, flicker_weight: float = 0.0, mse_weight: float = 0.0):
        super().__init__()
        self.scale, self.perceptual_weight, self.flicker_weight = scale, perceptual_weight, flicker_weight
        self.mse_weight = mse_weight

    def forward(self, output: torch.Tensor, aux: dict, frame: dict, reference: torch.Tensor,
                valid: torch.Tensor | None = None, flicker: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
        """``output``, ``reference`` (N, 3, H, W) display values; ``valid`` is unused (the output was
        already replaced by the reference where it is false); ``flicker`` as ``MNSSLoss``."""
        structural = 1.0 - ssim(output, reference).mean()
        perceptual = pyramid_loss(output, reference)
        l1 = F.l1_loss(output, reference)
        mse = F.mse_loss(output, reference)
        flicker = output.new_zeros(()) if flicker is None else flicker
        total = structural + self.perceptual_weight * perceptual + l1 + self.mse_weight * mse + self.flicker_weight * flicker
        return {"total": total, "ssim": structural, "perceptual": perceptual, "l1": l1, "mse": mse, "flicker": flicker}

    def flicker(self, error: torch.Tensor, prev_error: torch.Tensor, motion: torch.Tensor, reset: torch.Tensor | None) -> torch.Tensor:
        """``model.losses.flicker_term``."""
        return flicker_term(error, prev_error, motion, reset)
