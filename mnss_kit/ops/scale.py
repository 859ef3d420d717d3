"""Upscaling factors: integer (2, 3, 4) and fractional (quality modes such as 1.5x and 1.7x).

A scale ``s`` is a number in ``[MIN_SCALE, MAX_SCALE]`` = [1.25, 4], the same on both axes.
An integral value is kept as an ``int`` (``2.0`` becomes ``2``), so a config or meta.json that
says ``scale: 2`` reads, writes and renders exactly as before fractional scales existed.

Sizes (FSR2's convention: the display size is given, the render size derived)::

    lr = round_half_up(hr / s)            per axis, computed exactly (s as the decimal it was written as)

so 1280x720 at 1.7 renders at 753x424 (752.94 -> 753, 423.53 -> 424) and at 1.5 at 853x480.
Given an LR size instead, ``hr = round_half_up(lr * s)``; this HR size gives the LR size back by the
rule above (``|hr / s - lr| <= 0.5 / s < 0.5``), so one invariant, ``lr == round_half_up(hr / s)``,
holds for data made either way.  An integer scale keeps the stricter old invariant
``hr == lr * s`` exactly.  The exact ratio of an axis is ``hr / lr`` (a :class:`Ratio` of integers, reduced:
1280/753 and 720/424 = 90/53 for 1280x720 at 1.7): what maps LR pixel positions to HR ones (as
FSR2 keeps its render and display sizes); the nominal ``s`` names the mode.

Crops: an LR offset ``x`` maps to the HR offset ``x * hr / lr``, a whole pixel only where ``x`` is a
multiple of the denominator ``q`` of the reduced ratio ``hr / lr = p / q``.  :func:`crop_step` gives
``q`` per axis (1 for an integer scale; 2 for 72/48 = 3/2; 753 for 1280/753, where only whole
frames align: render training data at sizes whose ratio is exactly ``s``, e.g. 1920x1080 -> 1280x720
at 1.5 or 1360x765 -> 800x450 at 1.7).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from ..errors import UserError

MIN_SCALE = 1.25
MAX_SCALE = 4
INTEGER_SCALES = (2, 3, 4)
# the denominator past which a scale written as a decimal is refused (1.2345678 is no quality mode)
MAX_SCALE_DENOMINATOR = 1000

Scale = int | float
# Why each model family takes integer scales only so far (a fractional scale has no s x s tile of HR
# pixels per LR pixel).  Here, with the scale rules, so data check (an earlier stage than model/) can
# name it too; ``model.family.check_data_scale`` refuses data with it.  A family that learns to take
# any scale leaves this map.
INTEGER_SCALE_ONLY = {
    "mnss": "its pixel insertion puts each LR sample into one of the s x s HR pixels of its tile",
    "fusesr": "its pixel unshuffle folds s x s HR pixels into channels",
    "ntaau": "its steering net's outputs are pixel-shuffled by s",
}  # ntaau_lr takes any scale: its net runs at LR and its TAAU maps HR pixels to LR by the exact ratio


class Ratio(NamedTuple):
    """An exact ratio ``num / den`` of positive integers, reduced (no ``fractions``: ops/ stays numpy-only)."""

    num: int
    den: int

    @classmethod
    def of(cls, num: int, den: int) -> "Ratio":
        g = math.gcd(int(num), int(den))
        return cls(int(num) // g, int(den) // g)

    def __float__(self) -> float:
        return self.num / self.den

    def __str__(self) -> str:
        return f"{self.num}/{self.den}"


def parse_scale(value, what: str = "scale") -> Scale:
    """A validated scale: an ``int`` when integral, else a ``float``; a one-line UserError otherwise.

    Takes a number or its text (``"1.5"``).  Refuses NaN, infinities, booleans, and anything
    outside [1.25, 4] (``1.0`` does not upscale, ``0.5`` downscales, ``9`` is past every mode)."""
    if isinstance(value, str):
        try:
            value = float(value.strip())
        except ValueError:
            raise UserError(f"{what} must be a number in [{MIN_SCALE}, {MAX_SCALE}], got '{value}'") from None
    if isinstance(value, bool) or not (isinstance(value, (int, float)) or hasattr(value, "__float__")):
        raise UserError(f"{what} must be a number in [{MIN_SCALE}, {MAX_SCALE}], got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise UserError(f"{what} must be a finite number in [{MIN_SCALE}, {MAX_SCALE}], got {number}")
    if not MIN_SCALE <= number <= MAX_SCALE:
        why = " (an upscaler needs a scale above 1)" if number <= 1.0 else ""
        raise UserError(f"{what} {_text(number)} is outside [{MIN_SCALE}, {MAX_SCALE}]{why}")
    if number.is_integer():
        return int(number)
    if as_fraction(number).den > MAX_SCALE_DENOMINATOR:
        raise UserError(f"{what} {number!r} has more than 3 decimals: give a quality mode such as 1.5 or 1.7")
    return number


def check_data_scale_is(data_scale: Scale, wanted: Scale | None, where) -> None:
    """The one-line refusal of data (at ``where``) whose scale is not the ``--scale`` asked for (None: any)."""
    if wanted is not None and data_scale != wanted:
        raise UserError(f"{where}: data is x{data_scale} but --scale is {wanted}")


def is_integer(scale: Scale) -> bool:
    """An integer scale: every HR pixel belongs to one LR pixel's ``s x s`` tile."""
    return isinstance(scale, int) or float(scale).is_integer()


def as_fraction(scale: Scale) -> Ratio:
    """The scale as the exact decimal it was written as (1.7 is 17/10, not the nearest double)."""
    if isinstance(scale, int) or float(scale).is_integer():
        return Ratio(int(scale), 1)
    text = repr(float(scale))
    if "e" in text or "E" in text or "." not in text:
        return Ratio.of(*float(scale).as_integer_ratio())
    whole, decimals = text.split(".")
    return Ratio.of(int(whole + decimals), 10 ** len(decimals))


def lr_size_for(hr_size, scale: Scale) -> tuple[int, int]:
    """``round_half_up(hr / s)`` per axis: the render size of a display size (1280x720 at 1.7: 753x424)."""
    num, den = as_fraction(scale)
    return tuple((2 * int(v) * den + num) // (2 * num) for v in hr_size)  # floor(hr * den / num + 1/2), exactly


def hr_size_for(lr_size, scale: Scale) -> tuple[int, int]:
    """The display size of a render size: ``lr * s`` for an integer scale, else ``round_half_up(lr * s)``
    (which :func:`lr_size_for` maps back to ``lr_size``)."""
    if isinstance(scale, int):
        return tuple(int(v) * scale for v in lr_size)
    num, den = as_fraction(scale)
    return tuple((2 * int(v) * num + den) // (2 * den) for v in lr_size)  # floor(lr * num / den + 1/2)


def size_mismatch(lr_size, hr_size, scale: Scale) -> str | None:
    """Why ``lr_size`` and ``hr_size`` do not belong together at ``scale``, or None when they do."""
    lr, hr = tuple(int(v) for v in lr_size), tuple(int(v) for v in hr_size)
    if isinstance(scale, int) or float(scale).is_integer():
        s = int(scale)
        if hr != (lr[0] * s, lr[1] * s):
            return f"hr_size {hr} is not scale {s} x lr_size {lr}"
        return None
    expected = lr_size_for(hr, scale)
    if lr != expected:
        return f"lr_size {lr} is not round(hr_size {hr} / {scale}) = {expected} (round half up, per axis)"
    return None


def axis_ratios(lr_size, hr_size) -> tuple[Ratio, Ratio]:
    """The exact ``hr / lr`` of each axis ``(x, y)``, reduced."""
    return Ratio.of(hr_size[0], lr_size[0]), Ratio.of(hr_size[1], lr_size[1])


def crop_step(lr_size, hr_size) -> tuple[int, int]:
    """LR pixels ``(x, y)`` whose multiples map to whole HR pixels: the ratios' denominators."""
    rx, ry = axis_ratios(lr_size, hr_size)
    return rx.den, ry.den


def lr_to_hr(value: int, ratio: Ratio, what: str = "offset") -> int:
    """An LR pixel count or offset in HR pixels; a UserError unless it maps to a whole pixel."""
    hr, rest = divmod(int(value) * ratio.num, ratio.den)
    if rest:
        raise UserError(f"LR {what} {value} maps to {value * ratio.num / ratio.den:g} HR pixels at ratio {ratio}: "
                        f"not a whole pixel (use multiples of {ratio.den})")
    return hr


def resize_bilinear(image, size, offset=(0.0, 0.0)):
    """``(h, w, C)`` float32 -> ``(H, W, C)`` at ``size = (W, H)``, bilinear, clamp-to-edge: HR pixel
    centre ``X + 0.5`` reads the LR image at ``(X + 0.5) * w / W - offset`` (LR pixels, the jitter).
    The fractional-scale counterpart of ``ops.resample.upsample_bilinear`` (which an integer scale keeps)."""
    import numpy as np

    from .resample import bilinear_sample

    h, w = image.shape[:2]
    width, height = int(size[0]), int(size[1])
    xs = ((np.arange(width, dtype=np.float64) + 0.5) * (w / width) - float(offset[0])).astype(np.float32)
    ys = ((np.arange(height, dtype=np.float64) + 0.5) * (h / height) - float(offset[1])).astype(np.float32)
    y, x = np.meshgrid(ys, xs, indexing="ij")
    return bilinear_sample(image, x, y)


def upsample_motion_to(motion_lr, scale: Scale, hr_size):
    """LR motion ``(h, w, 2)`` in LR pixels -> HR motion at ``hr_size = (W, H)`` in HR pixels.

    An integer scale is ``ops.warp.upsample_motion`` itself (bit for bit); a fractional one resizes
    bilinearly and multiplies each axis by its exact ratio ``W / w``, ``H / h``."""
    import numpy as np

    if is_integer(scale):
        from .warp import upsample_motion

        return upsample_motion(motion_lr, int(scale))
    h, w = motion_lr.shape[:2]
    out = resize_bilinear(motion_lr, hr_size)
    return out * np.array([hr_size[0] / w, hr_size[1] / h], dtype=np.float32)


def upsample_nearest_to(image, scale: Scale, hr_size):
    """``(h, w, C)`` -> ``(H, W, C)`` nearest (depth: an object edge keeps one depth or the other):
    ``np.repeat`` at an integer scale, else HR pixel ``X`` takes LR pixel ``floor((X + 0.5) * w / W)``."""
    import numpy as np

    if is_integer(scale):
        s = int(scale)
        return np.repeat(np.repeat(image, s, axis=0), s, axis=1)
    h, w = image.shape[:2]
    cols = np.minimum(((np.arange(hr_size[0]) * 2 + 1) * w) // (2 * hr_size[0]), w - 1)
    rows = np.minimum(((np.arange(hr_size[1]) * 2 + 1) * h) // (2 * hr_size[1]), h - 1)
    return image[rows][:, cols]


def scale_label(scale: Scale) -> str:
    """``x2``, ``x1.5``."""
    return f"x{_text(scale)}"


def _text(number) -> str:
    return str(int(number)) if float(number).is_integer() and math.isfinite(float(number)) else f"{float(number):g}"
