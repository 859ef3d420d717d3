"""Training augmentations: a window's inputs degraded as engines send them, drawn per window.

``train.augment`` maps each name to the probability that a training window gets it::

    ldr8           LR colour rounded to 8 bits (``variants.ldr8_colour``)
    depth8/16      LR depth stored as reversed hardware depth of 8 or 16 bits, read back
                   (``variants.hardware_depth_bits``); at most one of the two per window
    motion_noise   LR motion plus Gaussian noise of ``variants.MOTION_NOISE_PX`` pixels
    exposure       the scene's light scaled by 2^u, u uniform in [-1, 1]: colour and reference
                   through the display transform, the linear emissive buffers scaled
    motion_dilate  LR motion of the nearest-depth pixel of each 3x3 (``engine_motion.dilated``)
    motion_pack8   LR motion through the 8-bit pair packing (``engine_motion.packed8``)
    motion_half    LR motion through 16-bit floats in UV units (``engine_motion.half_float``); at
                   most one of the two packings per window
    taa_reference  the target is the native TAA render (``hr/reference_taa``) instead of the
                   16-sample box one: an engine's "ground truth" is its own anti-aliased frame

The draws come from ``(seed, epoch, window index)``, as the crops do, so a window's augmentation
does not depend on the worker that loads it.  Validation windows are never augmented.  The same
degradations as files, for testing a model on them: ``mnss-kit data variant``.
"""

from __future__ import annotations

import numpy as np

from ..ops import colour
from . import format as fmt
from . import engine_motion
from .variants import MOTION_NOISE_PX, hardware_depth_bits, ldr8_colour, noisy_motion

# new names go last: a config's draws (one per name it lists, in this order) stay what they were
AUGMENTATIONS = ("ldr8", "depth8", "depth16", "motion_noise", "exposure", "motion_dilate", "motion_pack8", "motion_half",
                 "taa_reference")
TAA_REFERENCE_KEY = "hr_reference_taa"  # the window key the loader gives hr/reference_taa when taa_reference is drawn from
PER_FRAME_MOTION = {"motion_pack8": engine_motion.packed8, "motion_half": engine_motion.half_float}
EXPOSURE_STOPS = 1.0  # exposure scale 2^u, |u| <= this


def check_augment(augment: dict) -> None:
    """``ValueError`` naming an unknown augmentation or a probability outside [0, 1]."""
    for name, p in augment.items():
        if name not in AUGMENTATIONS:
            raise ValueError(f"unknown augmentation '{name}' (one of {', '.join(AUGMENTATIONS)})")
        if not isinstance(p, (int, float)) or not 0.0 <= float(p) <= 1.0:
            raise ValueError(f"augment.{name} is a probability in [0, 1], got {p!r}")


def draw(augment: dict, rng: np.random.Generator) -> list[str]:
    """The augmentations one window gets (one uniform draw per name, in AUGMENTATIONS order)."""
    chosen = [name for name in AUGMENTATIONS if name in augment and rng.random() < float(augment[name])]
    for kept, dropped in (("depth8", "depth16"), ("motion_pack8", "motion_half")):
        if kept in chosen and dropped in chosen:
            chosen.remove(dropped)
    return chosen


def augment_window(arrays: dict[str, np.ndarray], meta: fmt.SequenceMeta, augment: dict, rng: np.random.Generator) -> dict:
    """``arrays`` (a window's canonical float32 arrays, (T, C, h, w)) with the drawn augmentations applied."""
    out = dict(arrays)
    for name in draw(augment, rng):
        if name == "exposure":
            scale = np.float32(2.0 ** rng.uniform(-EXPOSURE_STOPS, EXPOSURE_STOPS))
            for key in ("color", "reference", TAA_REFERENCE_KEY):
                if key not in out:
                    continue
                out[key] = colour.to_display(colour.from_display(out[key]) * scale)
            for key in ("lr_emissive", "hr_emissive"):
                if key in out:
                    out[key] = (out[key] * scale).astype(np.float32)
        elif name == "ldr8":
            out["color"] = ldr8_colour(out["color"])
        elif name in ("depth8", "depth16"):
            out["depth"] = requantized_depth(out["depth"], meta, 8 if name == "depth8" else 16)
        elif name == "motion_noise":
            out["motion"] = noisy_motion(out["motion"], rng, MOTION_NOISE_PX)
        elif name == "motion_dilate":
            out["motion"] = _per_frame(lambda m, d: engine_motion.dilated(m, d), out["motion"], out["depth"])
        elif name in PER_FRAME_MOTION:
            out["motion"] = _per_frame(lambda m, _: PER_FRAME_MOTION[name](m), out["motion"], out["depth"])
        elif name == "taa_reference":
            out["reference"] = out[TAA_REFERENCE_KEY]
    out.pop(TAA_REFERENCE_KEY, None)  # every window carries the same keys, whichever target it drew
    return out


def _per_frame(fn, motion: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """``fn(motion (h, w, 2), depth (h, w, 1))`` on every frame of a (T, 2, h, w) window."""
    frames = [fn(m.transpose(1, 2, 0), d.transpose(1, 2, 0)).transpose(2, 0, 1) for m, d in zip(motion, depth)]
    return np.ascontiguousarray(np.stack(frames), dtype=np.float32)


def requantized_depth(depth: np.ndarray, meta: fmt.SequenceMeta, bits: int) -> np.ndarray:
    """Canonical depth (linear, [0, 1] from near to far) after a round trip through ``bits``-bit reversed
    hardware depth; rounded linearly when the data has no near plane (``near`` 0: no hardware depth)."""
    near, far = meta.near, meta.far
    if near <= 0.0:
        levels = float(2**bits - 1)
        return (np.round(depth.astype(np.float64) * levels) / levels).astype(np.float32)
    hardware = hardware_depth_bits(near + depth.astype(np.float64) * (far - near), near, far, bits)
    z = fmt.view_depth(hardware, near, far, reverse_z=True)
    return np.clip((z - near) / (far - near), 0.0, 1.0).astype(np.float32)
