"""Colour transforms between the linear HDR that datasets store and the display values the model sees."""

from __future__ import annotations

import numpy as np


def tonemap(linear: np.ndarray, exposure: float = 1.0) -> np.ndarray:
    """Reinhard per channel: ``x / (1 + x)`` of exposed linear colour; float32 in [0, 1)."""
    x = np.maximum(np.asarray(linear, dtype=np.float32) * np.float32(exposure), 0.0)
    return x / (1.0 + x)


def srgb_encode(x: np.ndarray) -> np.ndarray:
    """sRGB OETF on values in [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float32), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055).astype(np.float32)


def srgb_decode(x: np.ndarray) -> np.ndarray:
    """Inverse sRGB OETF on values in [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float32), 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4)).astype(np.float32)


def to_display(linear: np.ndarray, exposure: float = 1.0) -> np.ndarray:
    """Linear HDR -> display-referred [0, 1]: Reinhard tone map, then sRGB encoding."""
    return srgb_encode(tonemap(linear, exposure))


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Rec. 709 luma weights over the last axis."""
    rgb = np.asarray(rgb, dtype=np.float32)
    return rgb[..., 0] * 0.2126 + rgb[..., 1] * 0.7152 + rgb[..., 2] * 0.0722


# Largest tone-mapped value ``from_display`` inverts: Reinhard's x / (1 + x) reaches 1 only at
# infinity, and an fp16 or 8-bit display value of 1.0 would otherwise decode to inf.
TONEMAP_MAX = 0.999  # linear radiance 999


def from_display(display: np.ndarray, exposure: float = 1.0) -> np.ndarray:
    """Inverse of :func:`to_display`: display values -> linear HDR ``t / (1 - t)`` of the sRGB-decoded
    value ``t`` clamped to ``[0, TONEMAP_MAX]``, divided by ``exposure``; float32, finite."""
    t = np.minimum(srgb_decode(display), np.float32(TONEMAP_MAX))
    return (t / (np.float32(1.0) - t) / np.float32(exposure)).astype(np.float32)
