"""Sub-pixel jitter patterns, the only definition in the toolkit.

An offset ``(jx, jy)`` is in LR pixels relative to the LR pixel centre, each
in ``[-0.5, 0.5)`` (see ``conventions``).  For a scale ``s`` the LR pixel is a
tile of ``s x s`` HR pixels; sub-pixel ``(dx, dy)`` of the tile has its centre
at offset ``((dx + 0.5) / s - 0.5, (dy + 0.5) / s - 0.5)``.

Patterns
    ``grid``   one sample at every HR pixel centre of the tile, the order of MNSS
               (Yang et al. 2023).  x2: the sub-pixel moves by the speed
               cycles {1, 0} horizontally and {1, 1, 0} vertically (HR pixels
               per frame, wrapping inside the tile), period 12.  x3: a fixed
               9-frame order that covers the 3x3 tile, consecutive samples far
               apart.  Only scales 2 and 3.  Called ``mnss`` before; that
               spelling is still read (``RENAMED_PATTERNS``).
    ``halton`` Halton(2, 3), index starting at 1, period ``ceil(8 * s * s)``: ``8 s^2`` at an
               integer scale (32 at x2, as before), and at a fractional one FSR2's phase count
               (18 at 1.5x, 24 at 1.7x, ``s`` taken as the decimal it was written as).  The count
               grows with the number of HR pixels per LR pixel (``s^2``), so every HR pixel is
               sampled about 8 times per cycle at every scale; it is FSR2's, so captures from an
               engine running FSR2's jitter match this pattern phase for phase.  At a fractional
               scale an LR pixel is no tile of whole HR pixels, so there is no sub-pixel order to
               follow: Halton's low discrepancy is what spreads the samples.
    ``center`` no jitter (ablation), any scale.

Scales: an integer >= 2, or a fractional scale in [1.25, 4] (``ops.scale``); ``grid`` and the
sub-pixel functions (``subpixel_index`` and friends: MNSS's pixel insertion) take integers only.
"""

from __future__ import annotations

import numpy as np

from ..errors import UserError
from . import scale as scales

PATTERNS = ("grid", "halton", "center")
GRID_SCALES = (2, 3)  # the scales the grid pattern has an order for
# Earlier spellings of a pattern -> its name.  Data configs, ``--set jitter=...`` and datasets already
# on disk may give them; they mean the same offsets.  What is written (meta.json, bundles) uses PATTERNS.
RENAMED_PATTERNS = {"mnss": "grid"}

GRID_X2_SPEED_X = (1, 0)
GRID_X2_SPEED_Y = (1, 1, 0)
# Offsets this close (in sub-pixels) to a sub-pixel border count as on it; far above float32
# rounding of an offset, far below any pattern's distance from a border when not on one.
SUBPIXEL_BORDER_TOLERANCE = 1e-4
# (dx, dy) per frame; each step jumps to a different row and column of the tile.
GRID_X3_ORDER = ((1, 1), (0, 0), (2, 2), (0, 1), (2, 0), (1, 2), (0, 2), (2, 1), (1, 0))


def pattern_name(pattern: str) -> str:
    """Today's name of ``pattern``: an earlier spelling (``RENAMED_PATTERNS``) becomes the name it
    has now; any other text is returned as it is (``_check`` judges it)."""
    return RENAMED_PATTERNS.get(pattern, pattern)


def period(pattern: str, scale: int | float) -> int:
    """Number of frames after which the pattern repeats."""
    pattern, scale = _check(pattern, scale)
    if pattern == "grid":
        return 12 if scale == 2 else 9
    if pattern == "halton":
        if isinstance(scale, (int, np.integer)):
            return 8 * scale * scale
        num, den = scales.as_fraction(scale)
        return -(-8 * num * num // (den * den))  # ceil(8 s^2), exactly
    return 1


def subpixel_center_offset(dx: int, dy: int, scale: int) -> tuple[float, float]:
    """Offset (LR pixels) of the centre of sub-pixel ``(dx, dy)`` of an ``s x s`` tile."""
    return ((dx + 0.5) / scale - 0.5, (dy + 0.5) / scale - 0.5)


def halton(index: int, base: int) -> float:
    """Radical inverse of ``index`` in ``base``; in [0, 1)."""
    f, r = 1.0, 0.0
    i = index
    while i > 0:
        f /= base
        r += f * (i % base)
        i //= base
    return r


def grid_subpixels(scale: int, n: int) -> np.ndarray:
    """``(n, 2)`` int32 sub-pixel indices ``(dx, dy)`` of the grid pattern."""
    _check("grid", scale)
    out = np.zeros((n, 2), dtype=np.int32)
    if scale == 3:
        for t in range(n):
            out[t] = GRID_X3_ORDER[t % 9]
        return out
    x = y = 0
    for t in range(n):
        out[t] = (x, y)
        x = (x + GRID_X2_SPEED_X[t % len(GRID_X2_SPEED_X)]) % 2
        y = (y + GRID_X2_SPEED_Y[t % len(GRID_X2_SPEED_Y)]) % 2
    return out


def jitter_sequence(pattern: str, scale: int | float, n: int) -> np.ndarray:
    """``(n, 2)`` float64 jitter offsets ``(jx, jy)`` in LR pixels for frames ``0..n-1``."""
    pattern, scale = _check(pattern, scale)
    if pattern == "center":
        return np.zeros((n, 2))
    if pattern == "halton":
        p = period(pattern, scale)
        return np.array([(halton(t % p + 1, 2) - 0.5, halton(t % p + 1, 3) - 0.5) for t in range(n)])
    subs = grid_subpixels(scale, n)
    return np.array([subpixel_center_offset(int(dx), int(dy), scale) for dx, dy in subs])


def subpixel_index(offset: np.ndarray, scale: int) -> np.ndarray:
    """Sub-pixel ``(dx, dy)`` that contains the jittered sample; int32, shape of ``offset``.

    ``offset`` is ``(..., 2)`` in LR pixels.  The sample at LR pixel ``(i, j)``
    lands in HR pixel ``(s*i + dy, s*j + dx)``.  A sample on a sub-pixel border
    (the centre pattern at even scales, Halton thirds at scale 3) goes to the
    right/lower one; "on" means within ``SUBPIXEL_BORDER_TOLERANCE`` sub-pixels,
    so float32 and float64 offsets of the same pattern pick the same sub-pixel.
    """
    o = np.asarray(offset, dtype=np.float64)
    if not float(scale).is_integer():  # a quality mode (1.5x): no s x s tile, no sub-pixel; (0, 0) for the records
        return np.zeros(o.shape, np.int32)
    idx = np.floor((o + 0.5) * scale + SUBPIXEL_BORDER_TOLERANCE).astype(np.int32)
    return np.clip(idx, 0, scale - 1)


def _check(pattern: str, scale: int | float) -> tuple[str, int | float]:
    """``pattern`` by today's name (:func:`pattern_name`) and ``scale`` checked for it: an integer >= 2
    as it is, a float as ``ops.scale.parse_scale`` gives it (an integral float becomes the int)."""
    pattern = pattern_name(pattern)
    if pattern not in PATTERNS:
        raise UserError(f"unknown jitter pattern '{pattern}' (one of {', '.join(PATTERNS)})")
    if isinstance(scale, (float, np.floating)) and not isinstance(scale, bool):
        scale = scales.parse_scale(float(scale))  # in [1.25, 4], finite (a UserError otherwise); 2.0 -> 2
    if isinstance(scale, float):
        pass
    elif not isinstance(scale, (int, np.integer)) or isinstance(scale, bool) or scale < 2:
        raise UserError(f"scale must be an integer >= 2 or a fraction in [{scales.MIN_SCALE}, {scales.MAX_SCALE}], got {scale!r}")
    if pattern == "grid" and scale not in GRID_SCALES:
        raise UserError(f"the grid jitter pattern exists for scales 2 and 3, not {scale}"
                        + (": use jitter: halton (or center) at a fractional scale" if isinstance(scale, float) else ""))
    return pattern, scale
