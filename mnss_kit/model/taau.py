"""Temporal anti-aliasing upsampling (TAAU), in torch: the toolkit's baseline and the base the
``ntaau`` family steers.

TAAU in the style of Karis 2014 (Unreal Engine 4): jittered samples are accumulated into an HR
history that is reprojected with the upsampled motion and clamped to the current frame's
neighbourhood in YCoCg.  Per HR pixel, with ``W`` the reprojected history weight and ``w`` the
weight of this frame's nearby jittered samples (a Gaussian of their distance to the pixel
centre, ``sample_sigma`` HR pixels, 1 when a sample lands exactly on the pixel)::

    out = (W * clamp(history) + w * samples + p * spatial) / (W + w + p)
    W'  = min(W + w, 1 / alpha - 1)

so a pixel hit exactly by a sample after convergence blends with ``alpha`` (0.1), pixels far
from any sample blend less, and a fresh history (reset, disocclusion, off-screen) takes the
samples as they come.  ``spatial`` is the jitter-aware bicubic frame with a small prior weight
``p``, which fills pixels no sample has reached yet.

A :class:`Steer` scales ``W`` and ``w`` per pixel, widens or narrows the clamp box and adds a
bounded correction to the displayed colour only: the history keeps the uncorrected blend, so a
correction cannot feed back and build up over frames on a static camera.  :data:`NEUTRAL` (all
factors 1, no widening, no correction) is TAAU itself, so a steering net whose outputs are zero
starts as exactly this baseline.

Reprojection is bilinear.  Each bilinear fetch blurs, and under slow sub-pixel motion the blur
compounds frame after frame (Karis fetches history with a Catmull-Rom filter for this reason),
so the fetched history is sharpened by the inverse of that blur to first order and its weight
scaled by ``exp(-blur_penalty * (fx(1-fx) + fy(1-fy)))`` for fractional offsets ``fx, fy``.
Defaults were tuned on static, slow-pan, whole-pixel-pan and moving-object synthetic sequences.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F

from .layers import offscreen, upsample_motion, warp_bilinear
from ..ops import scale as scales
from ..ops.sanitize import COLOUR_MAX, FAR_DEPTH

Scale = int | float


def sanitize_colour(color: torch.Tensor) -> torch.Tensor:
    """``ops.sanitize.sanitize_colour`` in torch: NaN -> 0, clamped to +-COLOUR_MAX (Inf included)."""
    return torch.nan_to_num(color, nan=0.0, posinf=COLOUR_MAX, neginf=-COLOUR_MAX).clamp(-COLOUR_MAX, COLOUR_MAX)


def sanitize_depth(depth: torch.Tensor) -> torch.Tensor:
    """``ops.sanitize.sanitize_depth`` in torch: NaN and +-Inf -> FAR_DEPTH."""
    return torch.where(torch.isfinite(depth), depth, torch.full_like(depth, FAR_DEPTH))


def sanitize_motion(motion: torch.Tensor) -> torch.Tensor:
    """``ops.sanitize.sanitize_motion`` in torch: NaN and +-Inf -> 0."""
    return torch.where(torch.isfinite(motion), motion, torch.zeros_like(motion))


def colour_not_finite(color: torch.Tensor) -> torch.Tensor:
    """``ops.sanitize.colour_not_finite`` in torch: (N,C,h,w) -> (N,1,h,w) bool, a channel NaN or +-Inf."""
    return (~torch.isfinite(color)).any(dim=1, keepdim=True)


def sanitize_gbuffer(gbuffer: torch.Tensor) -> torch.Tensor:
    """``ops.sanitize.sanitize_gbuffer`` in torch: NaN -> 0, +-Inf -> +-COLOUR_MAX, finite values unchanged."""
    return torch.nan_to_num(gbuffer, nan=0.0, posinf=COLOUR_MAX, neginf=-COLOUR_MAX)


@dataclass(frozen=True)
class TAAUParams:
    alpha: float = 0.1
    sample_sigma: float = 0.35
    prior_weight: float = 0.05
    clip: str = "minmax"  # or "variance": mean +- gamma std
    gamma: float = 1.25
    sharpen: bool = True
    blur_penalty: float = 1.5

    def __post_init__(self):
        if self.clip not in ("minmax", "variance"):
            raise ValueError(f"clip must be 'minmax' or 'variance', got {self.clip!r}")

    @property
    def max_weight(self) -> float:
        return 1.0 / self.alpha - 1.0


@dataclass
class Steer:
    """Per-HR-pixel steering of one TAAU step, each ``(N, 1 or 3, H, W)`` or a scalar."""

    history_gain: torch.Tensor | float = 1.0  # multiplies the reprojected history weight W
    sample_gain: torch.Tensor | float = 1.0  # multiplies this frame's sample weight w
    box_widen: torch.Tensor | float = 0.0  # clamp box [lo - e (hi - lo), hi + e (hi - lo)]
    correction: torch.Tensor | float = 0.0  # added to the displayed colour (YCoCg), not to the history
    filter_axis: torch.Tensor | float = 0.0  # display filter: weight of each of the 4 axis neighbours
    filter_diagonal: torch.Tensor | float = 0.0  # display filter: weight of each of the 4 diagonal neighbours
    # spatial fallback in [0, 1]: the blend moves this far to the jitter-aware bicubic of this frame,
    # and its accumulated weight shrinks by as much (a history that cannot be trusted is not kept)
    fallback: torch.Tensor | float = 0.0


NEUTRAL = Steer()


def history_floor(hr_motion: torch.Tensor, history_gain_min: float, still_motion_px: float) -> torch.Tensor | float:
    """The least history gain per HR pixel (``ops.taau.history_floor``): ``history_gain_min`` where
    the surface moved less than ``still_motion_px`` HR pixels, fading linearly to 0 at that motion
    (everywhere when ``still_motion_px`` is 0: the motion is then not read).  ``hr_motion`` (N, 2, H, W)."""
    if still_motion_px <= 0.0:
        return history_gain_min
    motion_px = hr_motion.norm(dim=1, keepdim=True)
    return history_gain_min * (1.0 - motion_px / still_motion_px).clamp(0.0, 1.0)


def resample_spread(hr_motion: torch.Tensor) -> torch.Tensor:
    """``f (1 - f)`` per axis for the fractional part ``f`` of the HR motion (N, 2, H, W)
    (``ops.taau.resample_spread``): how much a bilinear fetch of the history there blurs it."""
    frac = hr_motion - torch.floor(hr_motion)
    return frac * (1.0 - frac)


def filter_gain(hr_motion: torch.Tensor, falloff: float) -> torch.Tensor | float:
    """What the display filter's weights are scaled by per HR pixel (``ops.taau.filter_gain``):
    ``exp(-falloff * (sx + sy))`` with the resample spread ``sx, sy``, so the filter blurs less
    where the history was just blurred by a fractional fetch; 1 when ``falloff`` is 0."""
    if falloff <= 0.0:
        return 1.0
    return torch.exp(-falloff * resample_spread(hr_motion).sum(dim=1, keepdim=True))


def box_widening(raw: torch.Tensor, box_bound: float) -> torch.Tensor:
    """The clamp box's widening per side, in units of its span (``ops.taau.box_widening``):
    ``box_bound`` tanh where the raw value is positive, 0.5 tanh where it narrows the box, which at
    -0.5 is its centre: a narrower box would be inverted."""
    t = torch.tanh(raw)
    return torch.where(t > 0, box_bound * t, 0.5 * t)


def steer_from_raw(raw: torch.Tensor, correction_bound: float, history_gain_min: torch.Tensor | float = 0.0,
                   filter_bound: float = 0.0, box_bound: float = 0.5,
                   filter_scale: torch.Tensor | float = 1.0) -> Steer:
    """A steering net's raw output (N, 6 or 8, H, W) mapped to its ranges (``ops.taau.steer_from_raw``):
    sample gain 2 sigmoid in (0, 2), history gain the same but at least ``history_gain_min``, box
    widening ``box_widening``, correction ``correction_bound`` tanh and, with 8 channels, the display
    filter's two weights ``filter_bound`` tanh times ``filter_scale`` (``filter_gain``)."""
    history_gain = torch.maximum(2.0 * torch.sigmoid(raw[:, 0:1]), torch.as_tensor(history_gain_min, dtype=raw.dtype))
    steer = Steer(history_gain=history_gain, sample_gain=2.0 * torch.sigmoid(raw[:, 1:2]),
                  box_widen=box_widening(raw[:, 2:3], box_bound), correction=correction_bound * torch.tanh(raw[:, 3:6]))
    if raw.shape[1] > 6:
        steer.filter_axis = filter_bound * torch.tanh(raw[:, 6:7]) * filter_scale
        steer.filter_diagonal = filter_bound * torch.tanh(raw[:, 7:8]) * filter_scale
    return steer


def rgb_to_ycocg(x: torch.Tensor) -> torch.Tensor:
    """``(N, 3, H, W)`` RGB -> YCoCg (luma, orange and green chroma)."""
    r, g, b = x.unbind(1)
    return torch.stack([0.25 * r + 0.5 * g + 0.25 * b, 0.5 * r - 0.5 * b, -0.25 * r + 0.5 * g - 0.25 * b], dim=1)


def ycocg_to_rgb(x: torch.Tensor) -> torch.Tensor:
    y, co, cg = x.unbind(1)
    return torch.stack([y + co - cg, y + cg, y - co - cg], dim=1)


def hr_dims(lr_hw: tuple[int, int], scale: Scale, hr_size=None) -> tuple[int, int]:
    """``(H, W)`` of the HR image for an LR image of ``(h, w)``: ``hr_size`` ``(W, H)`` when given,
    else ``h * s, w * s`` at an integer scale and ``round_half_up(lr * s)`` per axis at a fractional
    one (``ops.scale.hr_size_for``; data made from a display size may differ: give its ``hr_size``)."""
    h, w = int(lr_hw[0]), int(lr_hw[1])
    if hr_size is not None:
        return int(hr_size[1]), int(hr_size[0])
    if scales.is_integer(scale):
        return h * int(scale), w * int(scale)
    width, height = scales.hr_size_for((w, h), scale)
    return height, width


def is_tiled(lr_hw, hr_hw, scale: Scale) -> bool:
    """Every HR pixel is one of its LR pixel's ``s x s`` tile: an integer scale at exactly ``lr * s``
    (the integer code paths, bit for bit as before fractional scales)."""
    return scales.is_integer(scale) and tuple(hr_hw) == (int(lr_hw[0]) * int(scale), int(lr_hw[1]) * int(scale))


def nearest_index(n_hr: int, n_lr: int, device=None) -> torch.Tensor:
    """The LR pixel of each HR pixel along one axis (int64 ``(n_hr,)``): ``floor((X + 0.5) lr / hr)``,
    computed exactly in integers (``X // s`` at an integer scale)."""
    return ((2 * torch.arange(n_hr, device=device) + 1) * n_lr) // (2 * n_hr)


def nearest_up(x: torch.Tensor, s: Scale, hr_size=None) -> torch.Tensor:
    """``(N, C, h, w)`` -> ``(N, C, H, W)``, each HR pixel the LR pixel it maps to (``nearest_index``):
    ``repeat_interleave`` at an integer scale."""
    hr_hw = hr_dims(x.shape[-2:], s, hr_size)
    if is_tiled(x.shape[-2:], hr_hw, s):
        s = int(s)
        return x.repeat_interleave(s, dim=2).repeat_interleave(s, dim=3)
    rows = nearest_index(hr_hw[0], x.shape[-2], x.device)
    cols = nearest_index(hr_hw[1], x.shape[-1], x.device)
    return x.index_select(2, rows).index_select(3, cols)


def block_mean(x: torch.Tensor, lr_hw, scale: Scale) -> torch.Tensor:
    """The mean of each LR pixel's HR block ``(N, C, H, W)`` -> ``(N, C, h, w)``: the HR pixels whose
    nearest LR pixel it is (``nearest_index``); ``avg_pool2d`` over ``s x s`` tiles at an integer scale.
    At a ratio above 1 every LR pixel has at least one HR pixel (1 or 2 at 1.5x)."""
    h, w = int(lr_hw[0]), int(lr_hw[1])
    if is_tiled((h, w), x.shape[-2:], scale):
        return F.avg_pool2d(x, int(scale))
    n, c, hh, ww = x.shape
    rows, cols = nearest_index(hh, h, x.device), nearest_index(ww, w, x.device)
    sums = x.new_zeros(n, c, h, ww).index_add(2, rows, x)
    sums = x.new_zeros(n, c, h, w).index_add(3, cols, sums)
    count = torch.bincount(rows, minlength=h).view(h, 1) * torch.bincount(cols, minlength=w).view(1, w)
    return sums / count.to(x.dtype)


def hr_motion_of(motion: torch.Tensor, scale: Scale, hr_size=None) -> torch.Tensor:
    """LR motion ``(N, 2, h, w)`` in LR pixels -> HR motion in HR pixels: ``layers.upsample_motion``
    at an integer scale; else bilinear to the HR size (``F.interpolate(size=...)``, texel centres,
    clamp-to-edge) times each axis's exact ratio ``W / w``, ``H / h`` (``ops.scale.upsample_motion_to``)."""
    h, w = motion.shape[-2:]
    hr_hw = hr_dims((h, w), scale, hr_size)
    if is_tiled((h, w), hr_hw, scale):
        return upsample_motion(motion, int(scale))
    up = F.interpolate(motion, size=hr_hw, mode="bilinear", align_corners=False)
    ratio = torch.tensor([hr_hw[1] / w, hr_hw[0] / h], dtype=motion.dtype, device=motion.device).view(1, 2, 1, 1)
    return up * ratio


def bicubic_upsample(color: torch.Tensor, jitter: torch.Tensor, scale: Scale, hr_size=None) -> torch.Tensor:
    """Jitter-aware bicubic (A = -0.75, clamp-to-edge), not clamped: each LR sample placed where it
    was shaded (pixel centre + jitter).  ``(N, C, h, w)``, ``(N, 2)`` -> ``(N, C, h*s, w*s)`` (at a
    fractional scale ``(N, C, H, W)``, ``bicubic_resample``).  The colour is sanitized first (NaN /
    Inf in an input frame: the bicubic baseline costs one frame)."""
    hr_hw = hr_dims(color.shape[-2:], scale, hr_size)
    if not is_tiled(color.shape[-2:], hr_hw, scale):
        return bicubic_resample(color, jitter, (hr_hw[1], hr_hw[0]))
    color = sanitize_colour(color)
    n, _, h, w = color.shape
    s = int(scale)
    # HR pixel centres in LR pixel units; the LR texel grid is shifted by the jitter.
    xs = (torch.arange(w * s, dtype=color.dtype) + 0.5) / s
    ys = (torch.arange(h * s, dtype=color.dtype) + 0.5) / s
    jx = jitter[:, 0].to(color.dtype).view(n, 1, 1)
    jy = jitter[:, 1].to(color.dtype).view(n, 1, 1)
    gx = 2.0 * (xs.view(1, 1, -1) - jx) / w - 1.0
    gy = 2.0 * (ys.view(1, -1, 1) - jy) / h - 1.0
    grid = torch.stack(torch.broadcast_tensors(gx, gy), dim=-1)
    return F.grid_sample(color, grid, mode="bicubic", padding_mode="border", align_corners=False)


def bicubic_resample(color: torch.Tensor, jitter: torch.Tensor, size) -> torch.Tensor:
    """Jitter-aware bicubic at any scale (A = -0.75, clamp-to-edge), not clamped: ``(N, C, h, w)``,
    jitter ``(N, 2)`` LR pixels -> ``(N, C, H, W)`` for ``size = (W, H)``.

    The fractional-scale counterpart of ``bicubic_upsample`` (which integer scales keep, bit for
    bit): HR pixel centre ``X + 0.5`` sits at LR position ``(X + 0.5) * w / W`` (the exact ratio of
    each axis), and the LR texel grid is shifted by the jitter, as there."""
    color = sanitize_colour(color)
    n, _, h, w = color.shape
    width, height = int(size[0]), int(size[1])
    xs = (torch.arange(width, dtype=torch.float64) + 0.5) * (w / width)
    ys = (torch.arange(height, dtype=torch.float64) + 0.5) * (h / height)
    jx = jitter[:, 0].to(torch.float64).view(n, 1, 1)
    jy = jitter[:, 1].to(torch.float64).view(n, 1, 1)
    gx = 2.0 * (xs.view(1, 1, -1) - jx) / w - 1.0
    gy = 2.0 * (ys.view(1, -1, 1) - jy) / h - 1.0
    grid = torch.stack(torch.broadcast_tensors(gx, gy), dim=-1).to(color.dtype)
    return F.grid_sample(color, grid, mode="bicubic", padding_mode="border", align_corners=False)


def nearby_samples(current: torch.Tensor, jitter: torch.Tensor, scale: Scale, sigma: float,
                   hr_size=None) -> tuple[torch.Tensor, torch.Tensor]:
    """Gaussian-weighted mean of the 3x3 LR samples around each HR pixel and their total weight.

    Returns ``(N, 3, H, W)`` colour and ``(N, 1, H, W)`` weight.  HR pixel ``(Y, X)`` belongs to LR
    pixel ``nearest_index``; sample ``(i, j)`` sits at HR position ``rx (j + 0.5 + jx), ry (i + 0.5 + jy)``
    with the exact per-axis ratios ``rx = W / w``, ``ry = H / h`` (``s`` at an integer scale).
    """
    n, c, h, w = current.shape
    hh, ww = hr_dims((h, w), scale, hr_size)
    rx, ry = ww / w, hh / h
    padded = F.pad(current, (1, 1, 1, 1), mode="replicate")
    hr_x = torch.arange(ww, dtype=current.dtype)
    hr_y = torch.arange(hh, dtype=current.dtype)
    jx = jitter[:, 0].to(current.dtype).view(n, 1)
    jy = jitter[:, 1].to(current.dtype).view(n, 1)
    inv = -0.5 / (sigma**2)
    total = current.new_zeros(n, 1, hh, ww)
    acc = current.new_zeros(n, c, hh, ww)
    lr_y = nearest_index(hh, h).to(current.dtype) + 0.5
    lr_x = nearest_index(ww, w).to(current.dtype) + 0.5
    for dy in (-1, 0, 1):
        # the Gaussian is separable: weight = wy(row) * wx(column)
        wy = torch.exp(inv * (((lr_y + dy).view(1, -1) + jy) * ry - (hr_y + 0.5)) ** 2).view(n, 1, -1, 1)
        for dx in (-1, 0, 1):
            wx = torch.exp(inv * (((lr_x + dx).view(1, -1) + jx) * rx - (hr_x + 0.5)) ** 2).view(n, 1, 1, -1)
            wgt = wy * wx
            shifted = padded[:, :, 1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w]
            acc = acc + wgt * nearest_up(shifted, scale, (ww, hh))
            total = total + wgt
    return acc / total.clamp(min=1e-12), total


def neighbourhood_box(current: torch.Tensor, scale: Scale, params: TAAUParams,
                      hr_size=None) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-HR-pixel colour box ``(lo, hi)``, each ``(N, 3, H, W)``, from the 3x3 LR neighbourhood."""
    padded = F.pad(current, (1, 1, 1, 1), mode="replicate")
    if params.clip == "minmax":
        hi = F.max_pool2d(padded, 3, stride=1)
        lo = -F.max_pool2d(-padded, 3, stride=1)
    else:
        mean = F.avg_pool2d(padded, 3, stride=1)
        std = (F.avg_pool2d(padded * padded, 3, stride=1) - mean * mean).clamp(min=0).sqrt()
        lo, hi = mean - params.gamma * std, mean + params.gamma * std
    return nearest_up(lo, scale, hr_size), nearest_up(hi, scale, hr_size)


def undo_bilinear_blur(image: torch.Tensor, spread: torch.Tensor) -> torch.Tensor:
    """First-order inverse of the blur a bilinear fetch adds.

    A fetch at fractional offset ``f`` averages two texels with variance ``f (1 - f)`` per axis;
    subtracting half that variance times the second derivative (3-tap) restores the low
    frequencies, so repeated reprojection under slow motion does not smear the history.
    ``spread`` is ``(N, 2, H, W)``: ``f (1 - f)`` in x and y.
    """
    p = F.pad(image, (1, 1, 1, 1), mode="replicate")
    centre = p[:, :, 1:-1, 1:-1]
    dxx = p[:, :, 1:-1, :-2] + p[:, :, 1:-1, 2:] - 2.0 * centre
    dyy = p[:, :, :-2, 1:-1] + p[:, :, 2:, 1:-1] - 2.0 * centre
    return image - 0.5 * (spread[:, :1] * dxx + spread[:, 1:] * dyy)


def reprojected_history(history: torch.Tensor, weight: torch.Tensor, hr_motion: torch.Tensor, reset: torch.Tensor,
                        params: TAAUParams) -> tuple[torch.Tensor, torch.Tensor]:
    """The previous output ``history`` (N, 3, H, W) RGB and its weight (N, 1, H, W), warped to this
    frame by ``hr_motion`` (N, 2, H, W, the upsampled motion): colour in YCoCg, weight zero after a
    reset (``reset`` (N,) > 0.5) and where the motion points off-screen."""
    n = history.shape[0]
    warped = warp_bilinear(torch.cat([history, weight], dim=1), hr_motion)
    spread = resample_spread(hr_motion)
    keep = (reset.view(n, 1, 1, 1) < 0.5).to(history.dtype) * (~offscreen(hr_motion)).to(history.dtype)
    colour = rgb_to_ycocg(undo_bilinear_blur(warped[:, :3], spread) if params.sharpen else warped[:, :3])
    new_weight = warped[:, 3:] * keep * torch.exp(-params.blur_penalty * spread.sum(dim=1, keepdim=True))
    return colour, new_weight



def start_frame(frame: dict, state: dict | None, initial_state, like: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, dict]:
    """A TAAU-based model's reset flags (N,), its cut mask (N, 1, 1, 1) and the state a frame starts
    from: ``initial_state(frame)``, and a reset, when ``state`` is None.  ``like``: the (N, ...) colour."""
    n = like.shape[0]
    reset = frame.get("reset")
    reset = like.new_zeros(n) if reset is None else reset.to(like)
    if state is None:
        state, reset = initial_state(frame), like.new_ones(n)
    return reset, (reset > 0.5).view(n, 1, 1, 1), state

@dataclass
class TAAUInputs:
    """What one TAAU step computes before it blends (all YCoCg, HR unless noted)."""

    samples: torch.Tensor  # (N, 3, H, W) Gaussian mean of the nearby jittered samples
    sample_weight: torch.Tensor  # (N, 1, H, W)
    spatial: torch.Tensor  # (N, 3, H, W) jitter-aware bicubic
    lo: torch.Tensor  # clamp box
    hi: torch.Tensor
    history: torch.Tensor  # (N, 3, H, W) reprojected, not clamped
    history_weight: torch.Tensor  # (N, 1, H, W)
    hr_motion: torch.Tensor  # (N, 2, H, W) the motion upsampled once, for reprojection and the history floor


def taau_inputs(color: torch.Tensor, jitter: torch.Tensor, motion: torch.Tensor, reset: torch.Tensor, state: dict | None,
                scale: Scale, params: TAAUParams, hr_size=None) -> TAAUInputs:
    """The blend's inputs for LR ``color`` (N,3,h,w) RGB; ``state`` None: no history.  Colour and
    motion are sanitized (``ops.sanitize``): a NaN or Inf in one input frame never reaches the history.
    The HR size ``(W, H)``: ``hr_size``, else the history's, else ``hr_dims`` of the scale."""
    if hr_size is None and state is not None:
        hr_size = (state["history"].shape[-1], state["history"].shape[-2])
    hr_size = tuple(reversed(hr_dims(color.shape[-2:], scale, hr_size)))
    color, motion = sanitize_colour(color), sanitize_motion(motion)
    current = rgb_to_ycocg(color)
    samples, sample_weight = nearby_samples(current, jitter, scale, params.sample_sigma, hr_size)
    spatial = rgb_to_ycocg(bicubic_upsample(color, jitter, scale, hr_size))
    lo, hi = neighbourhood_box(current, scale, params, hr_size)
    hr_motion = hr_motion_of(motion, scale, hr_size)
    if state is None:
        history, weight = spatial, torch.zeros_like(spatial[:, :1])
    else:
        history, weight = reprojected_history(state["history"], state["weight"], hr_motion, reset, params)
    return TAAUInputs(samples, sample_weight, spatial, lo, hi, history, weight, hr_motion)


def display_filter(image: torch.Tensor, axis: torch.Tensor | float, diagonal: torch.Tensor | float) -> torch.Tensor:
    """``image`` plus ``axis`` times each of its 4 axis neighbours' differences to it and ``diagonal``
    times each of the 4 diagonal ones' (clamp-to-edge): a per-pixel 3x3 blur (weights > 0) or
    sharpen (< 0) whose taps sum to one; zero weights leave the image as it is."""
    if isinstance(axis, float) and isinstance(diagonal, float) and axis == 0.0 and diagonal == 0.0:
        return image
    p = F.pad(image, (1, 1, 1, 1), mode="replicate")
    centre = p[:, :, 1:-1, 1:-1]
    axial = p[:, :, :-2, 1:-1] + p[:, :, 2:, 1:-1] + p[:, :, 1:-1, :-2] + p[:, :, 1:-1, 2:] - 4.0 * centre
    diagonals = p[:, :, :-2, :-2] + p[:, :, :-2, 2:] + p[:, :, 2:, :-2] + p[:, :, 2:, 2:] - 4.0 * centre
    return image + axis * axial + diagonal * diagonals


def blend(inputs: TAAUInputs, params: TAAUParams, steer: Steer = NEUTRAL) -> tuple[torch.Tensor, dict]:
    """The displayed RGB ``(N, 3, H, W)`` in [0, 1] and the next state of one (steered) TAAU step:
    ``history`` the blend before the correction (RGB in [0, 1]), ``weight`` its accumulated sample weight.
    The display is that history through the display filter, plus the correction."""
    span = inputs.hi - inputs.lo
    lo, hi = inputs.lo - steer.box_widen * span, inputs.hi + steer.box_widen * span
    clamped = torch.minimum(torch.maximum(inputs.history, lo), hi)
    weight = inputs.history_weight * steer.history_gain
    sample_weight = inputs.sample_weight * steer.sample_gain
    p = params.prior_weight
    blended = (weight * clamped + sample_weight * inputs.samples + p * inputs.spatial) / (weight + sample_weight + p)
    accumulated = (weight + sample_weight).clamp(max=params.max_weight)
    if not (isinstance(steer.fallback, float) and steer.fallback == 0.0):
        blended = blended + steer.fallback * (inputs.spatial - blended)
        accumulated = accumulated * (1.0 - steer.fallback)
    history = ycocg_to_rgb(blended).clamp(0.0, 1.0)
    filtered = display_filter(history, steer.filter_axis, steer.filter_diagonal)
    output = (filtered + ycocg_to_rgb(_as_channels(steer.correction, history))).clamp(0.0, 1.0)
    return output, {"history": history, "weight": accumulated}


def _as_channels(correction: torch.Tensor | float, like: torch.Tensor) -> torch.Tensor:
    """A scalar correction as a (N, 3, H, W) tensor, for the colour transform."""
    return correction if isinstance(correction, torch.Tensor) else torch.full_like(like, float(correction))
