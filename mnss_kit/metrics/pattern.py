"""Fixed-pattern error: whether one sub-pixel phase of the upscaled image is systematically off.

A supersampler that paints a residual per output phase (the 2x2 positions of each LR pixel at x2)
shows a fixed dot pattern on moving edges and flat areas.  ``phase_offset`` measures it: the mean
signed error (output - reference, display space, all channels) of each of the ``scale x scale``
phases, and the largest distance of one of them from the mean over all pixels, in 8-bit levels.
An output without such a pattern scores about 0 whatever its overall error.
"""

from __future__ import annotations

import numpy as np

LEVELS = 255.0  # report in 8-bit display levels


def phase_means(output: np.ndarray, reference: np.ndarray, scale: int) -> np.ndarray:
    """``(scale, scale)`` mean signed error per sub-pixel phase (row phase, column phase)."""
    err = (np.asarray(output, np.float64) - np.asarray(reference, np.float64)).mean(axis=-1)
    h, w = (err.shape[0] // scale) * scale, (err.shape[1] // scale) * scale
    return err[:h, :w].reshape(h // scale, scale, w // scale, scale).mean(axis=(0, 2))


def phase_offset(output: np.ndarray, reference: np.ndarray, scale: int) -> float:
    """Largest |phase mean error - overall mean error| in 8-bit levels (see the module docstring)."""
    means = phase_means(output, reference, scale)
    return float(np.abs(means - means.mean()).max() * LEVELS)
