"""Input variants of a dataset sequence: the LR inputs as engines send them.

A variant rewrites a sequence's LR inputs the way a game capture degrades them, so a model can be
tested (and trained) on them; the HR buffers, which only the loss and the metrics read, are kept:

    ldr8              colour in display space, rounded to 8 bits (the reference converted to display
                      space too, unrounded): an LDR capture
    depth8/16         depth as reversed hardware depth rounded to 8 or 16 bits
    depth_near_guess  depth as reversed hardware depth whose recorded near plane is
                      NEAR_GUESS_FACTOR times the true one: a capture whose near plane is unknown
    motion_rigid      a share of moving objects move as one rigid body (skinned meshes whose
                      velocity comes from their root; ``engine_motion.rigid``)
    motion_absent     a share of moving objects have motion 0 (particles, transparents, objects
                      outside the velocity pass; ``engine_motion.absent``)
    camera_motion     LR motion recomputed from depth and the camera matrices alone: moving objects
                      get the motion of the camera, as in engines without per-object motion vectors
    motion_dilate     motion of the nearest-depth pixel of each 3x3 (Unreal's and FSR2's convention)
    motion_noise      LR motion plus Gaussian noise of MOTION_NOISE_PX pixels (seeded per sequence)
    motion_pack8      motion packed in 8-bit pairs, u = R/255 + G/255^2 (``engine_motion.pack_motion8``)
    motion_half       motion stored as 16-bit floats in UV units

``engine`` names the preset ENGINE: everything above a typical game capture does at once.  Un-jittered
or Halton input are render settings (``mnss-kit render CONFIG --set jitter=center``), not variants;
``eval.variant_sets`` pairs the preset with both.  Motion variants apply in the order above, to the
unquantized depth and motion, as an engine computes them before writing them out.  The array
functions (:func:`ldr8_colour`, :func:`hardware_depth_bits`, :func:`noisy_motion` and
``engine_motion``) are also the training augmentations' (``dataset/augment.py``).
"""

from __future__ import annotations

import shutil
import zlib
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..fileio import atomic_directory
from ..ops import colour
from . import engine_motion
from . import format as fmt

VARIANTS = ("ldr8", "depth8", "depth16", "depth_near_guess", "motion_rigid", "motion_absent", "camera_motion",
            "motion_dilate", "motion_noise", "motion_pack8", "motion_half")
ENGINE = ("ldr8", "depth8", "depth_near_guess", "motion_rigid", "motion_absent", "motion_dilate", "motion_pack8")
PRESETS = {"engine": ENGINE}
MOTION_VARIANTS = ("motion_rigid", "motion_absent", "camera_motion", "motion_dilate", "motion_noise",
                   "motion_pack8", "motion_half")
EXCLUSIVE = (("depth8", "depth16", "one depth precision"), ("motion_pack8", "motion_half", "one motion packing"),
             ("camera_motion", "motion_rigid", "camera_motion already drops every object's own motion"),
             ("camera_motion", "motion_absent", "camera_motion already drops every object's own motion"))
MOTION_NOISE_PX = 0.25
NEAR_GUESS_FACTOR = 4.0


def check_variants(names: list[str]) -> list[str]:
    """``names`` (presets expanded) in application order, after checking each is a variant, none
    repeats and no two exclude each other."""
    expanded = [v for n in names for v in PRESETS.get(n, (n,))]
    unknown = [n for n in expanded if n not in VARIANTS]
    if unknown:
        raise UserError(f"unknown input variant '{unknown[0]}' (one of {', '.join(VARIANTS + tuple(PRESETS))})")
    if len(set(expanded)) != len(expanded):
        raise UserError(f"input variants {', '.join(expanded)}: each at most once")
    for a, b, why in EXCLUSIVE:
        if a in expanded and b in expanded:
            raise UserError(f"input variants {a} and {b} do not go together: {why}")
    return [n for n in VARIANTS if n in expanded]


def write_variant_dataset(src: Path, out: Path, names: list[str], overwrite: bool = False) -> list[Path]:
    """Every sequence of ``src`` with the variants ``names`` applied, under ``out`` (written atomically)."""
    from .check import require_clean

    names = check_variants(names)
    seqs = fmt.find_sequences(src)
    for seq in seqs:  # a variant of data data check refuses would be refused in turn
        require_clean(seq)
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
    hardware = bits is not None or "depth_near_guess" in names
    cells = engine_motion.object_cells(meta.name)
    references = [b for b in fmt.REFERENCE_BUFFERS.values() if b in meta.buffers.get("hr", [])]
    for i in range(meta.frame_count):
        if "ldr8" in names:
            lr = fmt.canonical_colour(fmt.read_raw_buffer(src, "lr", "color", i), meta)
            fmt.write_buffer(dst, "lr", "color", i, ldr8_colour(lr))
            for ref in references:  # every reference a metric may read, in the display space the copy records
                fmt.write_buffer(dst, "hr", ref, i, fmt.canonical_colour(fmt.read_raw_buffer(src, "hr", ref, i), meta))
        if any(n in names for n in MOTION_VARIANTS):
            motion = engine_inputs_motion(src, meta, i, names, rng, cells)
            fmt.write_buffer(dst, "lr", "motion", i, _stored_motion(motion, meta, meta.lr_size).astype(np.float32))
        if hardware:
            fmt.write_buffer(dst, "lr", "depth", i, reversed_depth(fmt.read_raw_buffer(src, "lr", "depth", i), meta, bits))
    changes = {"scene": {**meta.scene, "input_variants": names}}
    if "ldr8" in names:
        changes.update(color_space="display", exposure=1.0)
    if hardware:
        changes.update(reverse_z=True, depth_encoding="hardware")
        if "depth" in meta.buffers.get("hr", []):
            for i in range(meta.frame_count):  # one reverse_z describes both resolutions: HR depth converted, unrounded
                fmt.write_buffer(dst, "hr", "depth", i, reversed_depth(fmt.read_raw_buffer(src, "hr", "depth", i), meta))
    if "depth_near_guess" in names:
        changes.update(near=meta.near * NEAR_GUESS_FACTOR)
    fmt.write_meta(dst, fmt.replace_meta(meta, **changes))


def engine_inputs_motion(src: Path, meta: fmt.SequenceMeta, index: int, names: list[str], rng: np.random.Generator,
                         cells: np.ndarray) -> np.ndarray:
    """Canonical LR motion of frame ``index`` with the motion variants of ``names`` applied in order."""
    motion = fmt.read_buffer(src, meta, "lr", "motion", index)
    needs_camera = any(n in names for n in ("camera_motion", "motion_rigid", "motion_absent"))
    camera = motion
    if needs_camera and index > 0:  # frame 0 has no previous camera: its motion is kept
        camera = fmt.canonical_motion(camera_motion(src, meta, index), meta, meta.lr_size)
    if "camera_motion" in names:
        motion = camera
    if "motion_rigid" in names or "motion_absent" in names:
        labels, count = engine_motion.moving_objects(motion, camera)
        if "motion_rigid" in names:
            motion = engine_motion.rigid(motion, engine_motion.objects_of_kind(labels, count, cells, "rigid"))
        if "motion_absent" in names:
            motion = engine_motion.absent(motion, engine_motion.objects_of_kind(labels, count, cells, "absent"))
    if "motion_dilate" in names:
        motion = engine_motion.dilated(motion, fmt.read_buffer(src, meta, "lr", "depth", index))
    if "motion_noise" in names:
        motion = noisy_motion(motion, rng, MOTION_NOISE_PX)
    if "motion_pack8" in names:
        motion = engine_motion.packed8(motion)
    if "motion_half" in names:
        motion = engine_motion.half_float(motion)
    return motion


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
