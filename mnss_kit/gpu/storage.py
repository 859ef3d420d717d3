"""What the GPU's storage does to values, for the numpy reference of the passes.

Values stored in an fp16 texture are rounded to float16 (nearest-even; the shaders round
explicitly because image stores may truncate), r32f / rg32f values stay float32, rgba8 display
values are 8-bit codes, and a ``vec2`` uniform holds float32.
"""

from __future__ import annotations

import numpy as np


def to_half(x: np.ndarray) -> np.ndarray:
    """float32 array of the float16 values nearest to ``x`` (ties to even): an fp16 texture's contents."""
    return np.asarray(x, dtype=np.float32).astype(np.float16).astype(np.float32)


def encode_unorm8(v: np.ndarray) -> np.ndarray:
    """Display values -> 8-bit codes ``rint(clamp(v, 0, 1) * 255)`` (float32 product, ties to even); uint8."""
    clamped = np.clip(np.asarray(v, dtype=np.float32), np.float32(0), np.float32(1))
    return np.rint(clamped * np.float32(255)).astype(np.uint8)


def as_jitter(jitter) -> np.ndarray:
    """``(2,)`` float32 jitter, as a ``vec2`` uniform holds it."""
    return np.asarray(jitter, dtype=np.float32).reshape(2)
