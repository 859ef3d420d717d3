"""Non-neural baselines with the model's per-frame interface.

``method(frame, state) -> (output, aux, state)`` on torch tensors
(``docs/architecture.md``); ``state`` is ``None`` on the first call.  The
evaluation loop runs these exactly like the model.

``Bicubic``  bicubic upsampling of the current LR frame only.
``TAAU``     temporal anti-aliasing upsampling in the style of Karis 2014
             (Unreal Engine 4): jittered samples accumulated into an HR
             history that is reprojected with the upsampled motion vectors
             and clamped to the current frame's neighbourhood in YCoCg.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from ..ops.warp import offscreen, upsample_motion, warp_bilinear


class Bicubic:
    """Bicubic upsampling (A = -0.75, clamp-to-edge), output clamped to [0, 1].

    Jitter-aware by default: each LR sample is placed where it was really
    shaded (pixel centre + jitter), which is worth about a decibel over
    pretending it sits at the pixel centre.  ``jitter_aware=False`` gives
    plain ``F.interpolate(mode="bicubic", align_corners=False)``.
    """

    def __init__(self, scale: int, jitter_aware: bool = True):
        self.scale = int(scale)
        self.jitter_aware = jitter_aware

    def upsample(self, color: torch.Tensor, jitter: torch.Tensor) -> torch.Tensor:
        """``(N, C, h, w)`` and jitter ``(N, 2)`` LR pixels -> ``(N, C, h*s, w*s)``, not clamped."""
        if not self.jitter_aware:
            return F.interpolate(color, scale_factor=self.scale, mode="bicubic", align_corners=False)
        n, _, h, w = color.shape
        s = self.scale
        # HR pixel centres in LR pixel units; the LR texel grid is shifted by the jitter.
        xs = (torch.arange(w * s, dtype=color.dtype) + 0.5) / s
        ys = (torch.arange(h * s, dtype=color.dtype) + 0.5) / s
        jx = jitter[:, 0].to(color.dtype).view(n, 1, 1)
        jy = jitter[:, 1].to(color.dtype).view(n, 1, 1)
        gx = 2.0 * (xs.view(1, 1, -1) - jx) / w - 1.0
        gy = 2.0 * (ys.view(1, -1, 1) - jy) / h - 1.0
        grid = torch.stack(torch.broadcast_tensors(gx, gy), dim=-1)
        return F.grid_sample(color, grid, mode="bicubic", padding_mode="border", align_corners=False)

    def __call__(self, frame: dict, state):
        return self.upsample(frame["color"], frame["jitter"]).clamp(0.0, 1.0), {}, state


def rgb_to_ycocg(x: torch.Tensor) -> torch.Tensor:
    """``(N, 3, H, W)`` RGB -> YCoCg (luma, orange and green chroma)."""
    r, g, b = x.unbind(1)
    return torch.stack([0.25 * r + 0.5 * g + 0.25 * b, 0.5 * r - 0.5 * b, -0.25 * r + 0.5 * g - 0.25 * b], dim=1)


def ycocg_to_rgb(x: torch.Tensor) -> torch.Tensor:
    y, co, cg = x.unbind(1)
    return torch.stack([y + co - cg, y + cg, y - co - cg], dim=1)


def _nearest_up(x: torch.Tensor, s: int) -> torch.Tensor:
    return x.repeat_interleave(s, dim=2).repeat_interleave(s, dim=3)


class TAAU:
    """Temporal anti-aliasing upsampler (accumulation form of the exponential blend).

    Per HR pixel, with ``W`` the reprojected history weight and ``w`` the
    weight of this frame's nearby jittered samples (a Gaussian of their
    distance to the pixel centre, ``sample_sigma`` HR pixels, 1 when a sample
    lands exactly on the pixel):

        out = (W * clamp(history) + w * samples + p * spatial) / (W + w + p)
        W'  = min(W + w, 1 / alpha - 1)

    so a pixel hit exactly by a sample after convergence blends with
    ``alpha`` (0.1), pixels far from any sample blend less, and a fresh
    history (reset, disocclusion, off-screen) takes the samples as they come.
    ``spatial`` is the jitter-aware bicubic frame with a small prior weight
    ``p``, which fills pixels no sample has reached yet.  History is clamped
    in YCoCg to the min/max (``clip="minmax"``) or mean +- ``gamma`` std
    (``clip="variance"``) of the 3x3 LR neighbourhood around each HR pixel.

    Reprojection is the reference bilinear warp.  Each bilinear fetch blurs,
    and under slow sub-pixel motion the blur compounds frame after frame
    (Karis fetches history with a Catmull-Rom filter for this reason), so the
    fetched history is sharpened by the inverse of that blur to first order
    (``sharpen``) and its weight is scaled by ``exp(-blur_penalty * (fx(1-fx)
    + fy(1-fy)))`` for fractional offsets ``fx, fy``.  Defaults were tuned on
    static, slow-pan, whole-pixel-pan and moving-object synthetic sequences.
    """

    def __init__(self, scale: int, alpha: float = 0.1, sample_sigma: float = 0.35, prior_weight: float = 0.05,
                 clip: str = "minmax", gamma: float = 1.25, sharpen: bool = True, blur_penalty: float = 1.5):
        if clip not in ("minmax", "variance"):
            raise ValueError(f"clip must be 'minmax' or 'variance', got {clip!r}")
        self.scale = int(scale)
        self.max_weight = 1.0 / alpha - 1.0
        self.sample_sigma = sample_sigma
        self.prior_weight = prior_weight
        self.clip = clip
        self.gamma = gamma
        self.sharpen = sharpen
        self.blur_penalty = blur_penalty
        self.spatial = Bicubic(scale, jitter_aware=True)

    def __call__(self, frame: dict, state):
        color, jitter = frame["color"], frame["jitter"]
        current = rgb_to_ycocg(color)
        samples, sample_weight = self._nearby_samples(current, jitter)
        spatial = rgb_to_ycocg(self.spatial.upsample(color, jitter))
        lo, hi = self._neighbourhood_box(current)
        history, weight = self._reprojected_history(frame, state, spatial)
        history = torch.minimum(torch.maximum(history, lo), hi)
        p = self.prior_weight
        blended = (weight * history + sample_weight * samples + p * spatial) / (weight + sample_weight + p)
        output = ycocg_to_rgb(blended).clamp(0.0, 1.0)
        new_state = {"history": rgb_to_ycocg(output), "weight": (weight + sample_weight).clamp(max=self.max_weight)}
        return output, {}, new_state

    def _nearby_samples(self, current: torch.Tensor, jitter: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Gaussian-weighted mean of the 3x3 LR samples around each HR pixel and their total weight.

        Returns ``(N, 3, H, W)`` colour and ``(N, 1, H, W)`` weight.  Sample
        ``(i, j)`` sits at HR position ``s * (j + 0.5 + jx), s * (i + 0.5 + jy)``.
        """
        n, _, h, w = current.shape
        s = self.scale
        padded = F.pad(current, (1, 1, 1, 1), mode="replicate")
        hr_x = torch.arange(w * s, dtype=current.dtype)
        hr_y = torch.arange(h * s, dtype=current.dtype)
        jx = jitter[:, 0].to(current.dtype).view(n, 1)
        jy = jitter[:, 1].to(current.dtype).view(n, 1)
        inv = -0.5 / (self.sample_sigma**2)
        total = torch.zeros(n, 1, h * s, w * s, dtype=current.dtype)
        acc = torch.zeros(n, 3, h * s, w * s, dtype=current.dtype)
        lr_y = torch.div(hr_y, s, rounding_mode="floor") + 0.5
        lr_x = torch.div(hr_x, s, rounding_mode="floor") + 0.5
        for dy in (-1, 0, 1):
            # the Gaussian is separable: weight = wy(row) * wx(column)
            wy = torch.exp(inv * (((lr_y + dy).view(1, -1) + jy) * s - (hr_y + 0.5)) ** 2).view(n, 1, -1, 1)
            for dx in (-1, 0, 1):
                wx = torch.exp(inv * (((lr_x + dx).view(1, -1) + jx) * s - (hr_x + 0.5)) ** 2).view(n, 1, 1, -1)
                wgt = wy * wx
                shifted = padded[:, :, 1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w]
                acc += wgt * _nearest_up(shifted, s)
                total += wgt
        return acc / total.clamp(min=1e-12), total

    def _neighbourhood_box(self, current: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Per-HR-pixel colour box ``(lo, hi)``, each ``(N, 3, H, W)``, from the 3x3 LR neighbourhood."""
        padded = F.pad(current, (1, 1, 1, 1), mode="replicate")
        if self.clip == "minmax":
            hi = F.max_pool2d(padded, 3, stride=1)
            lo = -F.max_pool2d(-padded, 3, stride=1)
        else:
            mean = F.avg_pool2d(padded, 3, stride=1)
            std = (F.avg_pool2d(padded * padded, 3, stride=1) - mean * mean).clamp(min=0).sqrt()
            lo, hi = mean - self.gamma * std, mean + self.gamma * std
        return _nearest_up(lo, self.scale), _nearest_up(hi, self.scale)

    def _reprojected_history(self, frame: dict, state, fallback: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """History colour ``(N, 3, H, W)`` and weight ``(N, 1, H, W)`` warped to this frame.

        The weight is zero after a reset, without a state, and where the
        motion points off-screen.  Warping uses the reference numpy warp.
        """
        n, _, hh, ww = fallback.shape
        if state is None:
            return fallback, torch.zeros(n, 1, hh, ww, dtype=fallback.dtype)
        packed = torch.cat([state["history"], state["weight"]], dim=1).permute(0, 2, 3, 1).numpy()
        motion = frame["motion"].permute(0, 2, 3, 1).numpy()
        warped = np.empty_like(packed)
        spread = np.empty(packed.shape[:3] + (2,), np.float32)
        for i in range(n):
            mv = upsample_motion(motion[i], self.scale)
            warped[i] = warp_bilinear(packed[i], mv)
            warped[i][offscreen(mv), 3] = 0.0
            frac = mv - np.floor(mv)
            spread[i] = frac * (1.0 - frac)
        warped_t = torch.from_numpy(warped).permute(0, 3, 1, 2).to(fallback.dtype)
        spread_t = torch.from_numpy(spread).permute(0, 3, 1, 2).to(fallback.dtype)
        keep = (frame["reset"].view(n, 1, 1, 1) < 0.5).to(fallback.dtype)
        colour = warped_t[:, :3]
        if self.sharpen:
            colour = _undo_bilinear_blur(colour, spread_t)
        weight = warped_t[:, 3:] * keep * torch.exp(-self.blur_penalty * spread_t.sum(dim=1, keepdim=True))
        return colour, weight


def _undo_bilinear_blur(image: torch.Tensor, spread: torch.Tensor) -> torch.Tensor:
    """First-order inverse of the blur a bilinear fetch adds.

    A fetch at fractional offset ``f`` averages two texels with variance
    ``f (1 - f)`` per axis; subtracting half that variance times the second
    derivative (3-tap) restores the low frequencies, so repeated
    reprojection under slow motion does not smear the history.
    ``spread`` is ``(N, 2, H, W)``: ``f (1 - f)`` in x and y.
    """
    p = F.pad(image, (1, 1, 1, 1), mode="replicate")
    centre = p[:, :, 1:-1, 1:-1]
    dxx = p[:, :, 1:-1, :-2] + p[:, :, 1:-1, 2:] - 2.0 * centre
    dyy = p[:, :, :-2, 1:-1] + p[:, :, 2:, 1:-1] - 2.0 * centre
    return image - 0.5 * (spread[:, :1] * dxx + spread[:, 1:] * dyy)


BASELINES = {"bicubic": Bicubic, "taau": TAAU}


def baseline_methods(scale: int, names=("bicubic", "taau")) -> dict:
    """``{name: per-frame callable}`` for the named baselines at ``scale``."""
    return {name: BASELINES[name](scale) for name in names}
