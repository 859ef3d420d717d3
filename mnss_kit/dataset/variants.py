"""Input variants of a dataset sequence: the LR inputs as engines send them.

A variant rewrites a sequence's LR inputs the way a game capture degrades them, so a model can be
tested (and trained) on them; the HR buffers, which only the loss and the metrics read, are kept:

    ldr8           colour in display space, rounded to 8 bits (the reference converted to display
                   space too, unrounded): an LDR capture
    depth8/16      depth as reversed hardware depth rounded to 8 or 16 bits
    motion_noise   LR motion plus Gaussian noise of MOTION_NOISE_PX pixels (seeded per sequence)
    camera_motion  LR motion recomputed from depth and the camera matrices alone: moving objects
                   get the motion of the camera, as in engines without per-object motion vectors

Variants apply in the order above except that ``camera_motion`` reads the unquantized depth, as
an engine computes it before writing depth out.  The array functions (:func:`ldr8_colour`,
:func:`hardware_depth_bits`, :func:`noisy_motion`) are also the training augmentations'
(``train/augment.py``).  Un-jittered or Halton input are render settings
(``mnss-kit render CONFIG --set jitter=center``), not variants.
"""

from __future__ import annotations

import shutil
import zlib
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..fileio import atomic_directory
from ..ops import colour
from . import format as fmt

VARIANTS = ("ldr8", "depth8", "depth16", "motion_noise", "camera_motion")
MOTION_NOISE_PX = 0.25


def check_variants(names: list[str]) -> list[str]:
    """``names`` in application order, after checking each is a variant and none repeats."""
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        raise UserError(f"unknown input variant '{unknown[0]}' (one of {', '.join(VARIANTS)})")
    if len(set(names)) != len(names) or ("depth8" in names and "depth16" in names):
        raise UserError(f"input variants {', '.join(names)}: each at most once, and one depth precision")
    return [n for n in VARIANTS if n in names]


def write_variant_dataset(src: Path, out: Path, names: list[str], overwrite: bool = False) -> list[Path]:
    """Every sequence of ``src`` with the variants ``names`` applied, under ``out`` (written atomically)."""
    names = check_variants(names)
    seqs = fmt.find_sequences(src)
    with atomic_directory(out, overwrite=overwrite) as staging:
        for seq in seqs:
            write_variant(seq, staging / seq.name, names)
    return [out / s.name for s in seqs]


def write_variant(src: Path, dst: Path, names: list[str]) -> None:
    """One sequence ``src`` rewritten into ``dst`` with the variants ``names`` (checked) applied."""
    meta = fmt.read_meta(src)
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns(".cache"))
    rng = np.random.default_rng(zlib.crc32(meta.name.encode()))
    bits = 8 if "depth8" in names else 16 if "depth16" in names else None
    for i in range(meta.frame_count):
        if "ldr8" in names:
            lr = fmt.canonical_colour(fmt.read_raw_buffer(src, "lr", "color", i), meta)
            fmt.write_buffer(dst, "lr", "color", i, ldr8_colour(lr))
            fmt.write_buffer(dst, "hr", "reference", i, fmt.canonical_colour(fmt.read_raw_buffer(src, "hr", "reference", i), meta))
        if "camera_motion" in names:
            fmt.write_buffer(dst, "lr", "motion", i, camera_motion(src, meta, i) if i > 0 else fmt.read_raw_buffer(src, "lr", "motion", i))
        if "motion_noise" in names:
            motion = fmt.read_raw_buffer(dst, "lr", "motion", i)
            fmt.write_buffer(dst, "lr", "motion", i, noisy_motion(motion, rng, MOTION_NOISE_PX / meta.motion.scale))
        if bits:
            fmt.write_buffer(dst, "lr", "depth", i, reversed_depth(fmt.read_raw_buffer(src, "lr", "depth", i), meta, bits))
    changes = {"scene": {**meta.scene, "input_variants": names}}
    if "ldr8" in names:
        changes.update(color_space="display", exposure=1.0)
    if bits:
        changes.update(reverse_z=True, depth_encoding="hardware")
        for i in range(meta.frame_count):  # one reverse_z describes both resolutions: HR depth converted, unrounded
            fmt.write_buffer(dst, "hr", "depth", i, reversed_depth(fmt.read_raw_buffer(src, "hr", "depth", i), meta))
    fmt.write_meta(dst, fmt.replace_meta(meta, **changes))


def ldr8_colour(display: np.ndarray) -> np.ndarray:
    """Display values rounded to 8 bits, as an LDR capture stores them."""
    return (np.round(np.asarray(display, np.float32) * np.float32(255.0)) / np.float32(255.0)).astype(np.float32)


def noisy_motion(motion: np.ndarray, rng: np.random.Generator, sigma: float) -> np.ndarray:
    """Motion plus independent Gaussian noise of ``sigma`` (in the motion's own units) per component."""
    return (motion + rng.normal(0.0, sigma, motion.shape)).astype(np.float32)


def hardware_depth_bits(z: np.ndarray, near: float, far: float, bits: int | None = None) -> np.ndarray:
    """View depth ``z`` as reversed hardware depth (near 1, far 0), rounded to ``bits`` bits when given."""
    z = np.maximum(np.asarray(z, np.float64), near)
    forward = (1.0 - near / z) / (1.0 - near / far)  # inverse of fmt.view_depth
    reverse = 1.0 - np.clip(forward, 0.0, 1.0)
    if bits is not None:
        levels = float(2 ** bits - 1)
        reverse = np.round(reverse * levels) / levels
    return reverse.astype(np.float32)


def reversed_depth(raw: np.ndarray, meta: fmt.SequenceMeta, bits: int | None = None) -> np.ndarray:
    """Stored depth as reversed hardware depth (near 1, far 0), rounded to ``bits`` bits when given."""
    if meta.depth_encoding == "hardware":
        z = fmt.view_depth(raw, meta.near, meta.far, meta.reverse_z)
    else:
        z = raw.astype(np.float64)
    return hardware_depth_bits(z, meta.near, meta.far, bits)


def camera_motion(seq: Path, meta: fmt.SequenceMeta, index: int) -> np.ndarray:
    """LR motion of frame ``index`` (stored conventions) from its depth and the camera matrices alone."""
    frame, prev = meta.frames[index], meta.frames[index - 1]
    if not frame.view or not frame.proj or not prev.view or not prev.proj:
        raise UserError(f"{seq}: camera_motion needs the view and proj matrices of frames {index - 1} and {index} in meta.json")
    w, h = meta.lr_size
    depth = fmt.read_raw_buffer(seq, "lr", "depth", index)[..., 0]
    z = fmt.view_depth(depth, meta.near, meta.far, meta.reverse_z) if meta.depth_encoding == "hardware" else depth.astype(np.float64)
    # the unjittered screen position each pixel sampled: its centre plus the frame's jitter
    sx = np.arange(w)[None, :] + 0.5 + frame.jitter[0]
    sy = np.arange(h)[:, None] + 0.5 + frame.jitter[1]
    proj, view = _matrix(frame.proj), _matrix(frame.view)
    x_ndc, y_ndc = 2.0 * sx / w - 1.0, 1.0 - 2.0 * sy / h
    view_pos = np.stack(np.broadcast_arrays((x_ndc - proj[0, 2]) * z / proj[0, 0], (y_ndc - proj[1, 2]) * z / proj[1, 1],
                                            -z, np.ones_like(z)), axis=-1)
    world = view_pos @ np.linalg.inv(view).T
    clip = world @ (_matrix(prev.proj) @ _matrix(prev.view)).T
    ndc = clip[..., :2] / np.where(np.abs(clip[..., 3:4]) > 1e-12, clip[..., 3:4], 1e-12)
    prev_x, prev_y = (ndc[..., 0] + 1.0) * 0.5 * w, (1.0 - ndc[..., 1]) * 0.5 * h
    canonical = np.stack([prev_x - sx, prev_y - sy], axis=-1)
    return _stored_motion(canonical, meta, (w, h)).astype(np.float32)


def _stored_motion(canonical: np.ndarray, meta: fmt.SequenceMeta, size: tuple[int, int]) -> np.ndarray:
    """Canonical motion (pixels, +y down, to the previous frame) in the sequence's stored convention
    (the inverse of ``fmt.canonical_motion``)."""
    m = canonical.copy()
    if meta.motion.points_to == "current":
        m = -m
    if meta.motion.y_axis == "up":
        m[..., 1] = -m[..., 1]
    if meta.motion.units == "uv":
        m = m / np.array(size, dtype=np.float64)
    elif meta.motion.units == "ndc":
        m = m / (np.array(size, dtype=np.float64) / 2.0)
    return m / meta.motion.scale


def _matrix(flat: list[float]) -> np.ndarray:
    return np.asarray(flat, dtype=np.float64).reshape(4, 4)
