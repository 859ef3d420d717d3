"""Backward bilinear warp of a history buffer by motion vectors (reference definition)."""

from __future__ import annotations

import numpy as np

from .resample import bilinear_sample, pixel_grid, upsample_bilinear

# Warped depth where the surface was outside the previous frame: no history exists there.
# Canonical depth lies in [0, 1], so the inpainting's |depth - D_W| is at least 1 at such pixels.
OFFSCREEN_DEPTH = -1.0


def warp_bilinear(history: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """Fetch ``history`` (H, W, C) where each pixel's surface was in the previous frame.

    ``motion`` is ``(H, W, 2)`` in pixels of this resolution, pointing to the
    previous frame (``conventions``): ``out[y, x] = history(x + 0.5 + mx, y + 0.5 + my)``,
    bilinear, clamp-to-edge.  Returns ``(H, W, C)`` float32.
    """
    h, w = history.shape[:2]
    if motion.shape[:2] != (h, w):
        raise ValueError(f"motion {motion.shape[:2]} and history {(h, w)} differ in size")
    x, y = pixel_grid(h, w)
    mv = np.asarray(motion, dtype=np.float32)
    return bilinear_sample(history, x + mv[..., 0], y + mv[..., 1])


def offscreen(motion: np.ndarray) -> np.ndarray:
    """``(H, W)`` bool: pixels whose motion ``(H, W, 2)`` points outside the previous frame."""
    h, w = motion.shape[:2]
    x, y = pixel_grid(h, w)
    px = x + np.asarray(motion[..., 0], np.float32)
    py = y + np.asarray(motion[..., 1], np.float32)
    return (px < 0) | (px >= w) | (py < 0) | (py >= h)


def warp_depth(depth: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """``warp_bilinear`` of an HR depth ``(H, W, 1)``, :data:`OFFSCREEN_DEPTH` where the motion leaves the frame."""
    warped = warp_bilinear(depth, motion)
    warped[offscreen(motion)] = OFFSCREEN_DEPTH
    return warped


def upsample_motion(motion_lr: np.ndarray, scale: int) -> np.ndarray:
    """LR motion (h, w, 2) in LR pixels -> HR motion (h*s, w*s, 2) in HR pixels.

    Bilinear resize (motion is rendered unjittered, so no offset), then
    multiplied by the scale because the units are pixels of each resolution.
    """
    return upsample_bilinear(motion_lr, scale) * np.float32(scale)
