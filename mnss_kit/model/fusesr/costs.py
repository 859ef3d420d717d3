"""Fixed-function MACs per HR output pixel of each FuseSR stage (unit costs in ``model.macs``)."""

from __future__ import annotations

from ..mac_units import BILINEAR

# display <-> linear per channel: sRGB curve (a pow and a few ops) and Reinhard (a divide, an add)
DISPLAY_TRANSFORM = 4


def fixed_macs(c) -> dict[str, float]:
    """Fixed-function MACs per HR output pixel of each stage of a FuseSR model with config ``c``."""
    lr = 1.0 / (c.scale * c.scale)  # LR elements per HR pixel
    # per channel: decode, subtract emissive, divide, encode
    demodulate = 3 * (2 * DISPLAY_TRANSFORM + 2) * lr
    remodulate = 3 * (2 * DISPLAY_TRANSFORM + 2)  # decode, multiply-add, encode at HR
    return {
        "warp_history": 2 * BILINEAR + 2 + 3 * BILINEAR,  # motion up (and x s), warp 3 channels
        "demodulate": demodulate,
        "encode": 0.0,
        "unshuffle": 0.0,  # a gather
        "backbone": 0.0,
        "remodulate": remodulate,
    }
