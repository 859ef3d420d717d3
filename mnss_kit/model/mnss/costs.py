"""Fixed-function MACs per HR output pixel of each MNSS stage (unit costs in ``model.macs``)."""

from __future__ import annotations

from ..mac_units import BILINEAR


def fixed_macs(c) -> dict[str, float]:
    """Fixed-function MACs per HR output pixel of each stage of an MNSS model with config ``c``."""
    lr = 1.0 / (c.scale * c.scale)  # LR elements per HR pixel
    with_history = c.history != "none"
    costs = {
        "warp": 2 * BILINEAR + 2 + 1 * BILINEAR + 4 * BILINEAR,  # motion up (and x s), depth up, warp 3+1 channels
        "inpaint": 3 * BILINEAR,  # I_U
        "aa": 3 + 3 * lr,  # avgpool of I_R, residual add at LR
        "insert": 0.0,
        "recon": 3.0,  # residual add at HR (the clamp is free)
        "enhance": 5 * 3,
    }
    if with_history:
        weight_up = BILINEAR if c.weight_upsample == "bilinear" else 0
        costs["inpaint"] += 4 * 2 * lr + 1 * lr + weight_up + 3 * 2  # |difference|, activation, upsample, blend
    return costs
