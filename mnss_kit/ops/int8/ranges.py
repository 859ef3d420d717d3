"""Integer ranges of the quantized dtypes and the ``(scale, zero_point)`` pair the int8 ops take."""

from __future__ import annotations

import numpy as np

INT8_MIN, INT8_MAX = -128, 127
INT16_MIN, INT16_MAX = -32768, 32767
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1
WEIGHT_MAX = 127  # symmetric int8 weights use [-127, 127]
QParams = tuple[float, int]  # (scale, zero_point)


def qrange(dtype: str | np.dtype) -> tuple[int, int]:
    """Inclusive integer range of an activation dtype (``int8`` or ``int16``)."""
    name = np.dtype(dtype).name
    if name == "int8":
        return INT8_MIN, INT8_MAX
    if name == "int16":
        return INT16_MIN, INT16_MAX
    if name == "int32":
        return INT32_MIN, INT32_MAX
    raise ValueError(f"no quantized range for dtype {name}")


def _clamp_int8(x: np.ndarray, clamp: tuple[int, int] | None) -> np.ndarray:
    lo, hi = clamp if clamp is not None else (INT8_MIN, INT8_MAX)
    return np.clip(x, lo, hi).astype(np.int8)
