"""PyTorch versions of the reference ops in ``mnss_kit.ops`` (batched, NCHW, differentiable).

Each function follows its numpy namesake and is tested against it in
``tests/ops/``.  Jitter is per sample, ``(N, 2)`` float in LR pixels, so one
batch may mix frames with different sub-pixel positions.  Coordinates follow
``ops.conventions``: pixel centres at +0.5, clamp-to-edge borders.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from ..ops.colour import TONEMAP_MAX
from ..ops.demodulation import FBETA_EPSILON
from ..ops.jitter import SUBPIXEL_BORDER_TOLERANCE
from ..ops.sharpen import ENHANCE_BETA, unsharp_kernel


def pixel_grid(h: int, w: int, like: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Pixel-centre coordinates ``(x, y)``, each ``(h, w)`` with the dtype and device of ``like``."""
    ys = torch.arange(h, dtype=like.dtype, device=like.device) + 0.5
    xs = torch.arange(w, dtype=like.dtype, device=like.device) + 0.5
    y, x = torch.meshgrid(ys, xs, indexing="ij")
    return x, y


def bilinear_sample(image: torch.Tensor, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Sample ``(N, C, H, W)`` at pixel coordinates ``x, y`` (each ``(N, H', W')``) -> ``(N, C, H', W')``.

    ``grid_sample`` with ``align_corners=False`` maps normalised ``g`` to texel
    index ``((g + 1) * W - 1) / 2``, i.e. pixel coordinate ``x`` to ``x - 0.5``;
    ``padding_mode="border"`` clamps that index to the edge texels, which is
    the reference's clamp-to-edge.
    """
    h, w = image.shape[-2:]
    grid = torch.stack((x * (2.0 / w) - 1.0, y * (2.0 / h) - 1.0), dim=-1)
    return F.grid_sample(image, grid, mode="bilinear", padding_mode="border", align_corners=False)


def upsample_bilinear(image: torch.Tensor, scale: int, offset: torch.Tensor | None = None) -> torch.Tensor:
    """``(N, C, h, w)`` -> ``(N, C, h*s, w*s)`` bilinear; ``offset`` ``(N, 2)`` LR pixels (the jitter) or None.

    The HR pixel at LR position ``u`` reads the LR image at ``u - offset``.
    """
    if offset is None:
        return F.interpolate(image, scale_factor=scale, mode="bilinear", align_corners=False)
    n = image.shape[0]
    h, w = image.shape[-2] * scale, image.shape[-1] * scale
    x, y = pixel_grid(h, w, image)
    lx = x / scale - offset[:, 0].view(n, 1, 1)
    ly = y / scale - offset[:, 1].view(n, 1, 1)
    return bilinear_sample(image, lx, ly)


def avgpool(image: torch.Tensor, scale: int) -> torch.Tensor:
    """Mean over each ``s x s`` tile: ``(N, C, H, W)`` -> ``(N, C, H/s, W/s)``."""
    return F.avg_pool2d(image, kernel_size=scale, stride=scale)


def warp_bilinear(history: torch.Tensor, motion: torch.Tensor) -> torch.Tensor:
    """Backward warp ``(N, C, H, W)`` by ``motion`` ``(N, 2, H, W)`` (pixels, pointing to the previous frame)."""
    h, w = history.shape[-2:]
    x, y = pixel_grid(h, w, history)
    return bilinear_sample(history, x + motion[:, 0], y + motion[:, 1])


def offscreen(motion: torch.Tensor) -> torch.Tensor:
    """``(N, 1, H, W)`` bool: pixels whose motion ``(N, 2, H, W)`` points outside the previous frame (``ops.warp.offscreen``)."""
    h, w = motion.shape[-2:]
    x, y = pixel_grid(h, w, motion)
    px, py = x + motion[:, 0], y + motion[:, 1]
    return ((px < 0) | (px >= w) | (py < 0) | (py >= h)).unsqueeze(1)


def upsample_motion(motion_lr: torch.Tensor, scale: int) -> torch.Tensor:
    """LR motion ``(N, 2, h, w)`` in LR pixels -> HR motion ``(N, 2, h*s, w*s)`` in HR pixels."""
    return upsample_bilinear(motion_lr, scale) * scale


def subpixel_index(jitter: torch.Tensor, scale: int) -> torch.Tensor:
    """``(N, 2)`` jitter -> ``(N, 2)`` int64 sub-pixel ``(dx, dy)``, as ``ops.jitter.subpixel_index``."""
    idx = torch.floor((jitter.double() + 0.5) * scale + SUBPIXEL_BORDER_TOLERANCE).long()
    return idx.clamp(0, scale - 1)


def sample_mask(jitter: torch.Tensor, scale: int, h: int, w: int) -> torch.Tensor:
    """``(N, 1, h*s, w*s)`` bool: True at the HR pixels sampled this frame."""
    sub = subpixel_index(jitter, scale).to(jitter.device)
    rows = torch.arange(h * scale, device=jitter.device) % scale
    cols = torch.arange(w * scale, device=jitter.device) % scale
    row_hit = rows.view(1, -1, 1) == sub[:, 1].view(-1, 1, 1)
    col_hit = cols.view(1, 1, -1) == sub[:, 0].view(-1, 1, 1)
    return (row_hit & col_hit).unsqueeze(1)


def extract_samples(hr: torch.Tensor, jitter: torch.Tensor, scale: int) -> torch.Tensor:
    """The HR pixels at each sample's sampled positions: ``(N, C, H, W)`` -> ``(N, C, H/s, W/s)``."""
    n, c, h, w = hr.shape
    sub = subpixel_index(jitter, scale).to(hr.device)
    # pixel_unshuffle puts HR pixel (s*i + dy, s*j + dx) of channel k at channel k*s*s + dy*s + dx.
    tiles = F.pixel_unshuffle(hr, scale).view(n, c, scale * scale, h // scale, w // scale)
    pick = (sub[:, 1] * scale + sub[:, 0]).view(n, 1, 1, 1, 1).expand(n, c, 1, h // scale, w // scale)
    return torch.gather(tiles, 2, pick).squeeze(2)


def insert_samples(hr: torch.Tensor, lr: torch.Tensor, jitter: torch.Tensor, scale: int) -> torch.Tensor:
    """``hr`` ``(N, C, H, W)`` with ``lr`` ``(N, C, H/s, W/s)`` written at the sampled positions."""
    mask = sample_mask(jitter, scale, lr.shape[-2], lr.shape[-1])
    return torch.where(mask, F.interpolate(lr, scale_factor=scale, mode="nearest"), hr)


def jittered_upsample(lr: torch.Tensor, jitter: torch.Tensor, scale: int) -> torch.Tensor:
    """``I_U``: LR samples ``(N, C, h, w)`` at their sampled HR positions, the rest bilinear -> ``(N, C, H, W)``."""
    return insert_samples(upsample_bilinear(lr, scale, offset=jitter), lr, jitter, scale)


def unsharp(image: torch.Tensor, beta: float = ENHANCE_BETA) -> torch.Tensor:
    """``ops.sharpen.unsharp`` on ``(N, C, H, W)``: fixed 3x3 kernel, edge texels repeat, clamped to [0, 1]."""
    c = image.shape[1]
    kernel = torch.from_numpy(unsharp_kernel(beta)).to(image).expand(c, 1, 3, 3)
    padded = F.pad(image, (1, 1, 1, 1), mode="replicate")
    return torch.clamp(F.conv2d(padded, kernel, groups=c), 0.0, 1.0)


def to_display(linear: torch.Tensor) -> torch.Tensor:
    """``ops.colour.to_display`` (exposure 1): Reinhard, then the sRGB encoding; values in [0, 1)."""
    x = torch.clamp(linear, min=0.0)
    t = x / (1.0 + x)
    return torch.where(t <= 0.0031308, 12.92 * t, 1.055 * torch.pow(torch.clamp(t, min=0.0031308), 1.0 / 2.4) - 0.055)


def from_display(display: torch.Tensor) -> torch.Tensor:
    """``ops.colour.from_display`` (exposure 1): sRGB decoding, then inverse Reinhard; finite."""
    d = torch.clamp(display, 0.0, 1.0)
    t = torch.where(d <= 0.04045, d / 12.92, torch.pow((torch.clamp(d, min=0.04045) + 0.055) / 1.055, 2.4))
    t = torch.clamp(t, max=TONEMAP_MAX)
    return t / (1.0 - t)


def demodulate(color: torch.Tensor, fbeta: torch.Tensor, emissive: torch.Tensor) -> torch.Tensor:
    """``ops.demodulation.demodulate``: display-encoded L, 0 where F_beta < ``FBETA_EPSILON`` (never divided)."""
    lit = torch.clamp(from_display(color) - emissive, min=0.0)
    dark = fbeta < FBETA_EPSILON
    return torch.where(dark, 0.0, to_display(lit / torch.clamp(fbeta, min=FBETA_EPSILON)))


def add_upsampled(residual: torch.Tensor, l: torch.Tensor, scale: int) -> torch.Tensor:
    """``ops.demodulation.add_upsampled``: clamp(nearest upsample of LR ``l`` + HR ``residual``, 0, 1) (NCHW)."""
    up = l.repeat_interleave(scale, dim=2).repeat_interleave(scale, dim=3)
    return torch.clamp(up + residual, 0.0, 1.0)


def remodulate(l: torch.Tensor, fbeta: torch.Tensor, emissive: torch.Tensor) -> torch.Tensor:
    """``ops.demodulation.remodulate``: display colour of ``F_beta * L + emissive`` (emissive alone where
    F_beta < ``FBETA_EPSILON``)."""
    reflected = torch.where(fbeta < FBETA_EPSILON, 0.0, fbeta * from_display(l))
    return to_display(reflected + emissive)
