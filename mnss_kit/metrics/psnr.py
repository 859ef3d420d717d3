"""PSNR, written once in numpy for every stage: eval, quantize, the emulator and dump comparison.

Identical images have an infinite PSNR and these functions return ``math.inf`` for them.  JSON has
no infinity: every JSON file the toolkit writes holds it as ``null`` (``fileio.json_safe``).
This module must not import torch: the emulator imports it.
"""

from __future__ import annotations

import math

import numpy as np


def mse_psnr(mse: float, peak: float = 1.0) -> float:
    """PSNR in dB of a mean squared error against ``peak``; ``inf`` when ``mse`` is 0."""
    return math.inf if mse == 0.0 else 10.0 * math.log10(peak * peak / mse)


def psnr(output: np.ndarray, reference: np.ndarray, data_range: float = 1.0) -> float:
    """PSNR in dB of two equal-shape arrays (any layout, computed in float64); ``inf`` when identical."""
    a = np.asarray(output, dtype=np.float64)
    b = np.asarray(reference, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"psnr: shapes differ {a.shape} vs {b.shape}")
    return mse_psnr(float(np.mean((a - b) ** 2)), data_range)
