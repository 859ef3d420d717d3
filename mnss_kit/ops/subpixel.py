"""Sub-pixel sample placement: where a jittered LR frame's samples land on the HR grid.

With jitter ``(jx, jy)`` and scale ``s``, every LR pixel ``(i, j)`` samples HR
pixel ``(s*i + dy, s*j + dx)`` where ``(dx, dy) = jitter.subpixel_index(jitter, s)``.
"""

from __future__ import annotations

import numpy as np

from .jitter import subpixel_index
from .resample import upsample_bilinear


def sample_mask(jitter: tuple[float, float], scale: int, h: int, w: int) -> np.ndarray:
    """``(h*s, w*s, 1)`` float32: 1 at the HR pixels sampled this frame, else 0."""
    dx, dy = (int(v) for v in subpixel_index(np.asarray(jitter), scale))
    mask = np.zeros((h * scale, w * scale, 1), dtype=np.float32)
    mask[dy::scale, dx::scale] = 1.0
    return mask


def extract_samples(hr: np.ndarray, jitter: tuple[float, float], scale: int) -> np.ndarray:
    """The HR pixels at this frame's sampled positions: ``(H, W, C)`` -> ``(H/s, W/s, C)``."""
    dx, dy = (int(v) for v in subpixel_index(np.asarray(jitter), scale))
    return np.ascontiguousarray(hr[dy::scale, dx::scale], dtype=np.float32)


def insert_samples(hr: np.ndarray, lr: np.ndarray, jitter: tuple[float, float], scale: int) -> np.ndarray:
    """Copy of ``hr`` (H, W, C) with ``lr`` (H/s, W/s, C) written at the sampled positions."""
    dx, dy = (int(v) for v in subpixel_index(np.asarray(jitter), scale))
    out = np.array(hr, dtype=np.float32, copy=True)
    out[dy::scale, dx::scale] = lr
    return out


def insert_valid_samples(hr: np.ndarray, lr: np.ndarray, jitter: tuple[float, float], scale: int) -> np.ndarray:
    """:func:`insert_samples`, except the LR texels whose first channel is negative
    (``ops.sanitize.NO_SAMPLE``: no sample there) leave ``hr`` as it is."""
    lr = np.asarray(lr, np.float32)
    keep = extract_samples(np.asarray(hr, np.float32), jitter, scale)
    return insert_samples(hr, np.where(lr[..., :1] < 0, keep, lr), jitter, scale)


def jittered_upsample(lr: np.ndarray, jitter: tuple[float, float], scale: int) -> np.ndarray:
    """``I_U`` of MNSS: LR samples at their sampled HR positions, the rest bilinearly filled.

    The bilinear fill accounts for where the samples really were (the jitter),
    then the exact samples overwrite their own HR pixels.
    """
    filled = upsample_bilinear(lr, scale, offset=(float(jitter[0]), float(jitter[1])))
    return insert_samples(filled, lr, jitter, scale)
