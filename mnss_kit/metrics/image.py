"""Per-image quality metrics in PyTorch: SSIM, and PSNR of tensors.

SSIM is written once, in PyTorch on ``(N, C, H, W)`` tensors, so the training
loss (1 - SSIM) and the evaluation use the very same function.  It follows
Wang et al. 2004: an 11x11 Gaussian window (sigma 1.5), K1 = 0.01, K2 = 0.03,
statistics over the window's valid positions only (no padding, as in the
authors' reference code), per channel, then averaged.  The numpy wrappers take
``(H, W, C)`` display images in [0, 1].  PSNR on arrays is in ``psnr.py`` (no torch);
``psnr_torch`` here is its batched tensor form for training.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

WINDOW_SIZE = 11
WINDOW_SIGMA = 1.5
K1, K2 = 0.01, 0.03


def psnr_torch(output: torch.Tensor, reference: torch.Tensor, data_range: float = 1.0) -> torch.Tensor:
    """PSNR in dB per batch item of ``(N, ...)`` tensors -> ``(N,)``; ``inf`` where identical."""
    mse = (output - reference).pow(2).flatten(1).mean(dim=1)
    return 10.0 * torch.log10(data_range * data_range / mse)


def gaussian_window(size: int = WINDOW_SIZE, sigma: float = WINDOW_SIGMA, dtype=torch.float32) -> torch.Tensor:
    """Normalised 1-D Gaussian taps ``(size,)``; the 2-D window is its outer product."""
    x = torch.arange(size, dtype=torch.float64) - (size - 1) / 2.0
    g = torch.exp(-(x * x) / (2.0 * sigma * sigma))
    return (g / g.sum()).to(dtype)


def _filter_valid(x: torch.Tensor, taps: torch.Tensor) -> torch.Tensor:
    """Separable Gaussian filter per channel, 'valid' positions only: (N, C, H, W) -> (N, C, H-k+1, W-k+1)."""
    c = x.shape[1]
    k = taps.numel()
    x = F.conv2d(x, taps.view(1, 1, 1, k).expand(c, 1, 1, k), groups=c)
    return F.conv2d(x, taps.view(1, 1, k, 1).expand(c, 1, k, 1), groups=c)


def ssim_map(a: torch.Tensor, b: torch.Tensor, data_range: float = 1.0, window_size: int = WINDOW_SIZE,
             sigma: float = WINDOW_SIGMA) -> torch.Tensor:
    """Local SSIM of ``(N, C, H, W)`` tensors -> ``(N, C, H - 10, W - 10)`` (for the 11x11 window).

    Differentiable.  Each output value is the SSIM of the window centred on
    input pixel ``(y + 5, x + 5)``.
    """
    if a.shape != b.shape or a.dim() != 4:
        raise ValueError(f"ssim expects two equal (N, C, H, W) tensors, got {tuple(a.shape)} and {tuple(b.shape)}")
    if min(a.shape[-2:]) < window_size:
        raise ValueError(f"ssim needs images of at least {window_size}x{window_size}, got {tuple(a.shape[-2:])}")
    taps = gaussian_window(window_size, sigma, a.dtype).to(a.device)
    c = a.shape[1]
    stats = _filter_valid(torch.cat([a, b, a * a, b * b, a * b], dim=1), taps)
    mu_a, mu_b, e_aa, e_bb, e_ab = torch.split(stats, c, dim=1)
    var_a = e_aa - mu_a * mu_a
    var_b = e_bb - mu_b * mu_b
    cov = e_ab - mu_a * mu_b
    c1 = (K1 * data_range) ** 2
    c2 = (K2 * data_range) ** 2
    num = (2.0 * mu_a * mu_b + c1) * (2.0 * cov + c2)
    den = (mu_a * mu_a + mu_b * mu_b + c1) * (var_a + var_b + c2)
    return num / den


def ssim(a: torch.Tensor, b: torch.Tensor, data_range: float = 1.0) -> torch.Tensor:
    """Mean SSIM per batch item of ``(N, C, H, W)`` tensors -> ``(N,)``; differentiable (loss = 1 - ssim)."""
    return ssim_map(a, b, data_range).flatten(1).mean(dim=1)


def to_tensor(image: np.ndarray) -> torch.Tensor:
    """``(H, W, C)`` array -> ``(1, C, H, W)`` float32 tensor."""
    img = np.asarray(image, dtype=np.float32)
    if img.ndim == 2:
        img = img[..., None]
    return torch.from_numpy(np.ascontiguousarray(img.transpose(2, 0, 1)))[None]


def to_image(tensor: torch.Tensor) -> np.ndarray:
    """``(1, C, H, W)`` or ``(C, H, W)`` tensor -> ``(H, W, C)`` float32 array."""
    t = tensor.detach()
    if t.dim() == 4:
        if t.shape[0] != 1:
            raise ValueError(f"to_image expects a batch of one, got {t.shape[0]}")
        t = t[0]
    return np.ascontiguousarray(t.permute(1, 2, 0).to(torch.float32).cpu().numpy())


def ssim_image(output: np.ndarray, reference: np.ndarray, data_range: float = 1.0) -> float:
    """SSIM of two ``(H, W, C)`` images (channels averaged), as a float."""
    with torch.no_grad():
        return float(ssim(to_tensor(output), to_tensor(reference), data_range)[0])


def ssim_map_image(output: np.ndarray, reference: np.ndarray, data_range: float = 1.0) -> np.ndarray:
    """Channel-averaged local SSIM of two ``(H, W, C)`` images -> ``(H - 10, W - 10)`` float32."""
    with torch.no_grad():
        m = ssim_map(to_tensor(output), to_tensor(reference), data_range)
    return m[0].mean(dim=0).numpy()
