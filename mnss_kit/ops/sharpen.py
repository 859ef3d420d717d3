"""MNSS output enhancement: a fixed unsharp kernel (reference definition).

    [[-b,    0, -b],
     [ 0, 1+4b,  0],
     [-b,    0, -b]]      b = ENHANCE_BETA

The kernel sums to 1, so flat regions are unchanged; it only boosts detail.
"""

from __future__ import annotations

import numpy as np

ENHANCE_BETA = 0.15


def unsharp_kernel(beta: float = ENHANCE_BETA) -> np.ndarray:
    """The ``(3, 3)`` float32 kernel above."""
    b = np.float32(beta)
    return np.array([[-b, 0, -b], [0, 1 + 4 * b, 0], [-b, 0, -b]], dtype=np.float32)


def unsharp(image: np.ndarray, beta: float = ENHANCE_BETA) -> np.ndarray:
    """Sharpen ``(H, W, C)`` display values; returns ``(H, W, C)`` float32 clipped to [0, 1].

    Border texels repeat (clamp-to-edge, as the warp).  Computed in float32:
    centre term first, then the four diagonal taps.
    """
    img = np.asarray(image, dtype=np.float32)
    b = np.float32(beta)
    p = np.pad(img, ((1, 1), (1, 1), (0, 0)), mode="edge")
    diagonals = p[:-2, :-2] + p[:-2, 2:] + p[2:, :-2] + p[2:, 2:]
    out = (np.float32(1) + np.float32(4) * b) * img - b * diagonals
    return np.clip(out, 0.0, 1.0).astype(np.float32)
