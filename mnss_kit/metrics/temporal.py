"""Temporal stability: IF-SSIM (MNSS, Yang et al. TVCG 2023) and the warping error.

IF-SSIM is the SSIM between the current output and the previous output
warped to the current frame by the motion vectors, over the pixels where the
two should agree:

1. Warp: ``warp_bilinear(out_{t-1}, motion)`` (backward, HR motion).
2. Pool: both images are 2x2 average-pooled, so the sub-pixel error of the
   bilinear warp itself does not count as flicker.
3. Disocclusion mask: a pixel is invalid where the warped previous depth
   differs from the current depth by 0.01 or more (canonical depth in [0, 1]),
   or where its motion points off-screen (no previous content exists).  A
   pooled pixel is valid only if its four HR pixels are.
4. Shading-change mask: the same warp is applied to the *reference* frames.
   Where the reference itself changes by more than a perceptual threshold
   (moving shadows, flickering lights, view-dependent highlights), a change in
   the output is correct, not flicker, so those pixels are excluded.  The
   threshold depends on brightness (see ``shading_threshold``).
5. SSIM (11x11 Gaussian window) between the pooled current and pooled warped
   previous output; invalid pixels of the warped image are replaced by the
   current image first, so they neither lower nor raise their neighbours'
   windows, then the SSIM map is averaged over the valid pixels.

The first frame of a sequence and frames after a reset have no IF-SSIM (NaN).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from ..ops.colour import luminance
from ..ops.resample import avgpool
from ..ops.warp import offscreen, warp_bilinear
from .image import WINDOW_SIZE, ssim_map, to_tensor

POOL = 2
DEPTH_TOLERANCE = 0.01
# Shading-change threshold in display units: T(Y) = SHADING_FLOOR + SHADING_WEBER * Y.
SHADING_FLOOR = 0.02
SHADING_WEBER = 0.04


def shading_threshold(luma: np.ndarray) -> np.ndarray:
    """Smallest visible change of display luma around level ``luma`` (display values in [0, 1]).

    ``T(Y) = 0.02 + 0.04 * Y``.  The MNSS paper gives this threshold only as a
    curve measured in a perception study; this is a Weber-like approximation
    of its shape.  Above the dark end the just-visible step grows in
    proportion to the level (Weber's law; 4 % of the display value, a little
    above the textbook 1-2 % of linear luminance, because game frames are
    watched in motion, not as static test patches).  In the dark end the
    threshold stops shrinking: display black level and ambient reflections
    hide differences below about 5 of 255 code values (the 0.02 floor).
    Display values are already gamma-encoded, so the threshold is applied to
    them directly.
    """
    return SHADING_FLOOR + SHADING_WEBER * np.asarray(luma, dtype=np.float32)


@dataclass(frozen=True)
class TemporalMasks:
    """Where frame t and frame t-1 can be compared.  Built once per frame, shared by all methods."""

    motion: np.ndarray  # (H, W, 2) float32, HR motion to the previous frame
    disoccluded: np.ndarray  # (H, W) bool, no valid history (depth test or off-screen)
    shading_changed: np.ndarray  # (H/2, W/2) bool, the reference changed visibly (pooled resolution)

    @property
    def valid_pooled(self) -> np.ndarray:
        """``(H/2, W/2)`` bool: pooled pixels used by IF-SSIM."""
        return ~_pool_any(self.disoccluded) & ~self.shading_changed

    @property
    def valid(self) -> np.ndarray:
        """``(H, W)`` bool: full-resolution pixels used by the warping error (odd edges excluded)."""
        h, w = self.disoccluded.shape
        out = np.zeros((h, w), dtype=bool)
        up = np.repeat(np.repeat(self.valid_pooled, POOL, axis=0), POOL, axis=1)
        out[: up.shape[0], : up.shape[1]] = up
        return out & ~self.disoccluded


def temporal_masks(
    reference: np.ndarray,
    reference_prev: np.ndarray,
    depth: np.ndarray,
    depth_prev: np.ndarray,
    motion: np.ndarray,
    depth_tolerance: float = DEPTH_TOLERANCE,
) -> TemporalMasks:
    """Masks for comparing frame t with frame t-1.

    ``reference``/``reference_prev`` are ``(H, W, 3)`` display images,
    ``depth``/``depth_prev`` ``(H, W, 1)`` canonical depth, ``motion``
    ``(H, W, 2)`` HR motion of frame t (canonical conventions).
    """
    motion = np.asarray(motion, dtype=np.float32)
    warped_depth = warp_bilinear(depth_prev, motion)[..., 0]
    disoccluded = (np.abs(np.asarray(depth, np.float32)[..., 0] - warped_depth) >= depth_tolerance) | offscreen(motion)
    ref_now = _pool(reference)
    ref_warped = _pool(warp_bilinear(reference_prev, motion))
    y_now, y_warped = luminance(ref_now), luminance(ref_warped)
    changed = np.abs(y_now - y_warped) > shading_threshold(0.5 * (y_now + y_warped))
    return TemporalMasks(motion=motion, disoccluded=disoccluded, shading_changed=changed)


def if_ssim(output: np.ndarray, output_prev: np.ndarray, masks: TemporalMasks) -> float:
    """IF-SSIM of ``(H, W, 3)`` output t against output t-1 (module docstring); NaN if nothing is valid."""
    return temporal_scores(output, output_prev, masks)[0]


def temporal_error(output: np.ndarray, output_prev: np.ndarray, masks: TemporalMasks) -> float:
    """Mean ``|out_t - warp(out_{t-1})|`` over valid HR pixels and channels; NaN if nothing is valid."""
    return temporal_scores(output, output_prev, masks)[1]


def temporal_scores(output: np.ndarray, output_prev: np.ndarray, masks: TemporalMasks) -> tuple[float, float]:
    """``(if_ssim, temporal_error)`` of ``(H, W, 3)`` outputs t and t-1, warping the previous one once."""
    warped = warp_bilinear(output_prev, masks.motion)
    return _if_ssim_warped(output, warped, masks), _warp_error(output, warped, masks)


def _if_ssim_warped(output: np.ndarray, warped_prev: np.ndarray, masks: TemporalMasks) -> float:
    now = _pool(output)
    if min(now.shape[:2]) < WINDOW_SIZE:
        raise ValueError(f"IF-SSIM needs frames of at least {POOL * WINDOW_SIZE} pixels per side")
    valid = masks.valid_pooled
    warped = np.where(valid[..., None], _pool(warped_prev), now)
    with torch.no_grad():
        local = ssim_map(to_tensor(now), to_tensor(warped))[0].mean(dim=0).numpy()
    r = WINDOW_SIZE // 2
    inside = valid[r : r + local.shape[0], r : r + local.shape[1]]
    return float(local[inside].mean()) if inside.any() else math.nan


def _warp_error(output: np.ndarray, warped_prev: np.ndarray, masks: TemporalMasks) -> float:
    diff = np.abs(np.asarray(output, np.float32) - warped_prev).mean(axis=-1)
    valid = masks.valid
    return float(diff[valid].mean()) if valid.any() else math.nan


def _pool(image: np.ndarray) -> np.ndarray:
    """2x2 average pool of ``(H, W, C)`` (an odd last row/column is dropped)."""
    h, w = image.shape[:2]
    return avgpool(np.asarray(image, np.float32)[: h - h % POOL, : w - w % POOL], POOL)


def _pool_any(mask: np.ndarray) -> np.ndarray:
    """2x2 'any' pool of an ``(H, W)`` bool mask."""
    h, w = mask.shape
    m = mask[: h - h % POOL, : w - w % POOL]
    return m.reshape(h // POOL, POOL, w // POOL, POOL).any(axis=(1, 3))
