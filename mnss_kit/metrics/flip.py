"""FLIP (NVIDIA, Andersson et al. 2020) through the ``flip-evaluator`` package."""

from __future__ import annotations

import numpy as np

from ..errors import UserError


def flip_error(output: np.ndarray, reference: np.ndarray, pixels_per_degree: float | None = None) -> float:
    """Mean LDR-FLIP error of ``(H, W, 3)`` display (sRGB) images in [0, 1]; 0 is identical.

    ``pixels_per_degree`` defaults to FLIP's own (67, a 0.7 m viewing distance
    from a 24" 4K monitor); a phone held at arm's length is closer to 60-90.
    """
    try:
        import flip_evaluator
    except ImportError:
        raise UserError("FLIP needs the flip-evaluator package (pip install flip-evaluator)") from None
    params = {} if pixels_per_degree is None else {"ppd": float(pixels_per_degree)}
    ref = np.ascontiguousarray(np.clip(reference, 0.0, 1.0), dtype=np.float32)
    test = np.ascontiguousarray(np.clip(output, 0.0, 1.0), dtype=np.float32)
    _, mean_error, _ = flip_evaluator.evaluate(ref, test, "LDR", applyMagma=False, parameters=params)
    return float(mean_error)
