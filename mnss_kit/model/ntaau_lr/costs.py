"""Fixed-function MACs per HR output pixel of each ntaau_lr stage (unit costs in ``model.macs``)."""

from __future__ import annotations

from ..mac_units import BILINEAR
from ..ntaau.costs import BICUBIC, TRANSCENDENTAL, history_floor


def fixed_macs(c) -> dict[str, float]:
    """Fixed-function MACs per HR output pixel of each stage of an ntaau_lr model with config ``c``."""
    lr = 1.0 / (c.scale * c.scale)  # LR elements per HR pixel
    reproject = 2 * BILINEAR + 2 + 4 * BILINEAR + 3 * 5 + 2 * 2 + TRANSCENDENTAL  # motion up, warp 3+1, blur undone, weight
    samples = 9 * (3 + 1 + 1) + 2 * 3 * TRANSCENDENTAL * lr  # 9 taps of colour and weight; separable Gaussian
    # per LR pixel: block means of 3 HR values, 3x3 nearest depth, its bilinear fetch, the change;
    # 8 motion differences; the trust ramp
    features = 3 * 9 + 3 + lr * (9 + BILINEAR + 3 + 8 * 3 + 4)
    # the 7 LR values upsampled, 6 activations, the trust gate, box, clamp, blend, fallback, RGB, filter;
    # the motion-dependent floor
    accumulate = 7 * BILINEAR + 6 * TRANSCENDENTAL + 4 + 3 * 4 + 6 + 3 * 3 + 3 * 2 + 4 + 9 * 3 + history_floor(c)
    return {"lr_gather": reproject + samples + 3 * BICUBIC + 9 + 3 + features, "steer": 0.0, "lr_accumulate": accumulate}
