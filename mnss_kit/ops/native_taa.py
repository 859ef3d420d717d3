"""Native-resolution temporal anti-aliasing: how an engine anti-aliases its own full-resolution frame.

The ``reference_taa`` buffer of the dataset is this TAA's output: what a studio holds as the
"ground truth" of its game (``docs/dataset.md``).  It is the classic TAA engines ship (Karis, "High
Quality Temporal Supersampling", SIGGRAPH 2014, Unreal Engine 4; Pedersen, "Temporal Reprojection
Anti-Aliasing in INSIDE", GDC 2016), at the output resolution, with fixed parameters.  It is not
the toolkit's TAAU baseline (``mnss_kit/model/taau.py``): no upsampling, nothing learned.

Each frame the scene is rendered once per pixel with the projection jittered by
``halton_offset(index)`` (Halton(2, 3), ``PHASES`` phases, in pixels).  Then, per pixel:

1. velocity: the motion vector of the nearest-depth pixel of the 3x3 neighbourhood, so the
   edge pixels of a moving object follow the object (Karis's "closest velocity");
2. history: the previous output fetched at ``p + velocity`` with a Catmull-Rom filter (16 taps,
   clamp-to-edge; ``"bilinear"`` for the cheaper fetch); a position off the screen has no history;
3. clip: the history is clipped towards the centre of the min/max box of the 3x3 current
   samples in YCoCg (Karis's AABB clip), which rejects stale or disoccluded history, then to
   RGB >= 0 (a YCoCg box reaches below zero in RGB; so does a Catmull-Rom overshoot);
4. blend: ``out = history + ALPHA * (current - history)``; with ``luma_weighted`` each term is
   weighted by ``1 / (1 + luma)`` first (Karis's anti-flicker weighting, biased towards dark).
   On a reset (camera cut, sequence start) or without history the output is the current sample.

On a static camera the output converges to the mean of the ``PHASES`` jittered samples (an 8-sample
box filter, exponentially weighted); on a moving camera the repeated resampling of the history and
the clip soften it: the softness of an engine's native frame.
"""

from __future__ import annotations

import numpy as np

from .jitter import halton
from .resample import bilinear_sample, pixel_grid

ALPHA = 0.1  # weight of the current frame in the exponential blend
PHASES = 8  # Halton(2, 3) jitter phases, index 1 .. PHASES
HISTORY_FILTERS = ("catmull_rom", "bilinear")
CLIP_EPSILON = 1e-6  # keeps the box's extent positive on a flat neighbourhood


def halton_offset(index: int, phases: int = PHASES) -> tuple[float, float]:
    """Jitter ``(jx, jy)`` in pixels (+y down) of frame ``index``: Halton(2, 3) at ``index % phases + 1``,
    each in ``(-0.5, 0.5)``."""
    i = index % phases + 1
    return halton(i, 2) - 0.5, halton(i, 3) - 0.5


def describe(alpha: float = ALPHA, phases: int = PHASES, history_filter: str = "catmull_rom", luma_weighted: bool = False) -> str:
    """One line naming the algorithm and its parameters (recorded in a rendered sequence's meta)."""
    weight = ", luma-weighted" if luma_weighted else ""
    return (f"native TAA (mnss_kit/ops/native_taa.py): Halton(2,3) {phases} phases, 1 sample per pixel, "
            f"nearest-depth 3x3 velocity, {history_filter} history, 3x3 YCoCg AABB clip, alpha {alpha}{weight}")


def native_taa_step(current: np.ndarray, motion: np.ndarray, depth: np.ndarray, history: np.ndarray | None,
                    reset: bool, alpha: float = ALPHA, history_filter: str = "catmull_rom",
                    luma_weighted: bool = False) -> np.ndarray:
    """One frame of the TAA; returns the output, which is also the next frame's ``history``.

    ``current`` (H, W, 3) float32: this frame's colour, one sample per pixel at the jittered
    position (linear, >= 0; the output is then >= 0 too).  ``motion`` (H, W, 2) float32: pixels of this resolution
    from the current to the previous position, +y down (the canonical convention), without jitter.
    ``depth`` (H, W) or (H, W, 1): smaller is nearer (hardware or linear depth, not reversed).
    ``history`` (H, W, 3) float32: the previous output, or None.  ``reset``: drop the history.
    Returns (H, W, 3) float32.
    """
    if history_filter not in HISTORY_FILTERS:
        raise ValueError(f"history_filter must be one of {HISTORY_FILTERS}, got '{history_filter}'")
    current = np.asarray(current, dtype=np.float32)
    if reset or history is None:
        return current.copy()
    h, w = current.shape[:2]
    velocity = nearest_depth_velocity(np.asarray(motion, np.float32), np.asarray(depth, np.float32).reshape(h, w))
    x, y = pixel_grid(h, w)
    px, py = x + velocity[..., 0], y + velocity[..., 1]
    fetch = catmull_rom_sample if history_filter == "catmull_rom" else bilinear_sample
    previous = fetch(np.asarray(history, np.float32), px, py)
    lo, hi = neighbourhood_box(rgb_to_ycocg(current))
    previous = np.maximum(ycocg_to_rgb(clip_towards_centre(rgb_to_ycocg(previous), lo, hi)), np.float32(0))
    a = np.float32(alpha)
    if luma_weighted:
        wc = a / (np.float32(1) + luma(current))
        wh = (np.float32(1) - a) / (np.float32(1) + luma(previous))
        out = (wc * current + wh * previous) / (wc + wh)
    else:
        out = previous + a * (current - previous)
    on_screen = ((px >= 0) & (px < w) & (py >= 0) & (py < h))[..., None]
    return np.where(on_screen, out, current).astype(np.float32)


def nearest_depth_velocity(motion: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(H, W, 2) float32: at each pixel the motion of the nearest-depth pixel of its 3x3 neighbourhood
    (edge pixels repeat the border; ties keep the first in row-major order, centre row included)."""
    h, w = depth.shape
    pd = np.pad(depth, 1, mode="edge")
    pm = np.pad(motion, ((1, 1), (1, 1), (0, 0)), mode="edge")
    best_depth = np.full((h, w), np.inf, np.float32)
    best = np.zeros((h, w, 2), np.float32)
    for dy in range(3):
        for dx in range(3):
            d = pd[dy:dy + h, dx:dx + w]
            nearer = d < best_depth
            best_depth = np.where(nearer, d, best_depth)
            best = np.where(nearer[..., None], pm[dy:dy + h, dx:dx + w], best)
    return best


def catmull_rom_weights(f: np.ndarray) -> tuple[np.ndarray, ...]:
    """The four Catmull-Rom weights of taps -1, 0, 1, 2 at fraction ``f`` in [0, 1); they sum to 1."""
    f2, f3 = f * f, f * f * f
    return (-0.5 * f3 + f2 - 0.5 * f, 1.5 * f3 - 2.5 * f2 + 1.0, -1.5 * f3 + 2.0 * f2 + 0.5 * f, 0.5 * f3 - 0.5 * f2)


def catmull_rom_sample(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Sample (H, W, C) float32 ``image`` at pixel coordinates ``x, y`` (centres at +0.5) with the
    4x4-tap Catmull-Rom filter, clamp-to-edge; returns ``x.shape + (C,)`` float32 (it can overshoot
    the neighbours, which the clip that follows removes)."""
    img = np.asarray(image, dtype=np.float32)
    h, w = img.shape[:2]
    fx = np.asarray(x, np.float32) - np.float32(0.5)
    fy = np.asarray(y, np.float32) - np.float32(0.5)
    x0, y0 = np.floor(fx), np.floor(fy)
    wx = catmull_rom_weights((fx - x0)[..., None])
    wy = catmull_rom_weights((fy - y0)[..., None])
    x0i, y0i = x0.astype(np.int64), y0.astype(np.int64)
    flat = img.reshape(h * w, -1)
    out = np.zeros(np.shape(fx) + (img.shape[2],), np.float32)
    for j in range(4):
        row = np.clip(y0i + j - 1, 0, h - 1) * w
        line = np.zeros_like(out)
        for i in range(4):
            line += np.take(flat, row + np.clip(x0i + i - 1, 0, w - 1), axis=0) * wx[i]
        out += line * wy[j]
    return out


def rgb_to_ycocg(rgb: np.ndarray) -> np.ndarray:
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return np.stack([0.25 * r + 0.5 * g + 0.25 * b, 0.5 * r - 0.5 * b, -0.25 * r + 0.5 * g - 0.25 * b], axis=-1).astype(np.float32)


def ycocg_to_rgb(ycocg: np.ndarray) -> np.ndarray:
    y, co, cg = ycocg[..., 0], ycocg[..., 1], ycocg[..., 2]
    return np.stack([y + co - cg, y + cg, y - co - cg], axis=-1).astype(np.float32)


def luma(rgb: np.ndarray) -> np.ndarray:
    """(H, W, 1) float32 Rec. 709 luma of linear RGB."""
    return (rgb @ np.array([0.2126, 0.7152, 0.0722], np.float32))[..., None].astype(np.float32)


def neighbourhood_box(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-channel min and max over each pixel's 3x3 neighbourhood (border repeated), (H, W, C) each."""
    h, w = image.shape[:2]
    padded = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="edge")
    taps = [padded[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)]
    return np.min(taps, axis=0), np.max(taps, axis=0)


def clip_towards_centre(value: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Move ``value`` along the line to the box centre until it is inside the box [lo, hi] (unchanged
    inside): keeps the hue of the history where a per-channel clamp would shift it."""
    centre = np.float32(0.5) * (hi + lo)
    extent = np.float32(0.5) * (hi - lo) + np.float32(CLIP_EPSILON)
    offset = value - centre
    outside = np.max(np.abs(offset) / extent, axis=-1, keepdims=True)
    return np.where(outside > 1, centre + offset / np.maximum(outside, np.float32(1)), value).astype(np.float32)
