"""Fixed-function MACs per HR output pixel of each ntaau stage (unit costs in ``model.macs``)."""

from __future__ import annotations

from ..mac_units import BILINEAR

TRANSCENDENTAL = 4  # one exp, sigmoid or tanh, counted as a few multiply-adds
BICUBIC = 16  # one bicubic sample of one channel: sixteen weighted taps


def fixed_macs(c) -> dict[str, float]:
    """Fixed-function MACs per HR output pixel of each stage of an ntaau model with config ``c``."""
    lr = 1.0 / (c.scale * c.scale)  # LR elements per HR pixel
    reproject = 2 * BILINEAR + 2 + 4 * BILINEAR + 3 * 5 + 2 * 2 + TRANSCENDENTAL  # motion up, warp 3+1, blur undone, weight
    samples = 9 * (3 + 1 + 1) + 2 * 3 * TRANSCENDENTAL * lr  # 9 taps of colour and weight; separable Gaussian
    return {
        "taau_gather": reproject + samples + 3 * BICUBIC + 9 + 9 * 3 * 2 * lr + 3 + 6 + 3,  # bicubic, YCoCg, box, features
        "steer": 0.0,
        # activations, box, clamp, blend, RGB; the motion-dependent floor, the display filter
        "taau_accumulate": 6 * TRANSCENDENTAL + 3 * 4 + 6 + 3 * 3 + 4 + 6 + history_floor(c) + display_filter(c),
    }


def history_floor(c) -> float:
    """The floor's fade: the HR motion at the pixel (bilinear, 2 channels), its length, the ramp."""
    return 2 * BILINEAR + 2 + TRANSCENDENTAL + 2 if c.still_motion_px > 0 else 0.0


def display_filter(c) -> float:
    """taau_filter_pass: two weights and the three correction values again, 9 taps of 3 channels; with
    a falloff, the HR motion at the pixel (bilinear, 2 channels), its resample spread and the fade."""
    if c.filter_bound <= 0:
        return 0.0
    falloff = 2 * BILINEAR + 2 * 2 + 2 + TRANSCENDENTAL + 2 if c.filter_falloff > 0 else 0.0
    return 5 * TRANSCENDENTAL + 9 * 3 + 3 * 3 + falloff
