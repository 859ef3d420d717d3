"""On-disk dataset format: one directory per sequence, one OpenEXR file per frame and buffer.

    SEQ/meta.json                      metadata (``SequenceMeta``)
    SEQ/lr/<buffer>/<frame:05d>.exr    low-resolution buffers (colour is jittered)
    SEQ/hr/<buffer>/<frame:05d>.exr    high-resolution buffers (``reference`` is the target)

``docs/dataset.md`` is the user-facing description; this module is the truth.
The engine's own conventions (depth encoding, reverse-Z, motion units and sign,
colour space) are recorded in ``meta.json`` and converted to the toolkit's
canonical ones (``mnss_kit.ops.conventions``) by ``read_buffer``, once, here.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from ..config import from_dict, to_dict
from ..errors import UserError
from ..fileio import atomic_write_json, read_json
from ..ops import colour
from ..ops import jitter as jitter_patterns
from ..ops import scale as scales
from . import exr

log = logging.getLogger(__name__)

FORMAT_NAME = "mnss-dataset"
FORMAT_VERSION = 1
META_FILE = "meta.json"


@dataclass(frozen=True)
class BufferSpec:
    channels: tuple[str, ...]
    half: bool  # stored as half float (else float32)


# Buffers by resolution.  Depth and motion stay float32: half float loses
# sub-pixel motion precision beyond ~64 px and depth precision near the far plane.
_RGB_HALF = BufferSpec(("R", "G", "B"), True)
_SCALAR_HALF = BufferSpec(("Y",), True)
# G-buffers and geometry exist at both resolutions.
_SHARED_BUFFERS = {
    "depth": BufferSpec(("Z",), False),
    "motion": BufferSpec(("R", "G"), False),
    "albedo": _RGB_HALF,
    "normal": _RGB_HALF,
    "roughness": _SCALAR_HALF,
    "metallic": _SCALAR_HALF,
    "fbeta": _RGB_HALF,
    "emissive": _RGB_HALF,
}
# Optional references besides the box-filtered ``reference``: an engine's own native frame,
# anti-aliased by its TAA (``ops/native_taa.py``) or by 4 rotated-grid samples.
REFERENCE_BUFFERS = {"box": "reference", "taa": "reference_taa", "4x": "reference_4x"}  # eval --reference
BUFFERS: dict[str, dict[str, BufferSpec]] = {
    "lr": {"color": _RGB_HALF, **_SHARED_BUFFERS},  # colour is jittered
    "hr": {"reference": _RGB_HALF, **_SHARED_BUFFERS,  # the supersampled target
           "reference_taa": _RGB_HALF, "reference_4x": _RGB_HALF},
}
REQUIRED_BUFFERS = {"lr": ("color", "depth", "motion"), "hr": ("reference",)}
COLOUR_BUFFERS = ("color", *REFERENCE_BUFFERS.values())  # same colour space and exposure as ``color``


@dataclass
class MotionConvention:
    units: Literal["pixels", "uv", "ndc"] = "pixels"  # pixels of the buffer's own resolution
    points_to: Literal["previous", "current"] = "previous"
    y_axis: Literal["down", "up"] = "down"
    scale: float = 1.0  # extra multiplier an engine applies (FSR2's motionVectorScale)


@dataclass
class FrameMeta:
    index: int
    jitter: tuple[float, float]  # LR pixels, +x right, +y down
    reset: bool = False  # camera cut: history is invalid
    time: float = 0.0
    # 4x4 matrices flattened row-major, column-vector convention (clip = proj @ view @ world)
    view: list[float] = field(default_factory=list)  # world -> view
    proj: list[float] = field(default_factory=list)  # view -> clip, unjittered


@dataclass
class SequenceMeta:
    format: str
    version: int
    name: str
    # an int (2, 3, 4), or a quality mode in [1.25, 4] (1.5, 1.7): ops.scale; lr = round_half_up(hr / s)
    # per axis, the exact ratio of an axis being hr_size / lr_size (an integer scale: hr = s * lr exactly)
    scale: int | float
    lr_size: tuple[int, int]  # (width, height)
    hr_size: tuple[int, int]
    jitter_pattern: str
    frames: list[FrameMeta]
    near: float = 0.1
    far: float = 1000.0
    reverse_z: bool = False
    depth_encoding: Literal["hardware", "linear"] = "hardware"
    motion: MotionConvention = field(default_factory=MotionConvention)
    color_space: Literal["linear_hdr", "display"] = "linear_hdr"
    exposure: float = 1.0
    buffers: dict[str, list[str]] = field(default_factory=lambda: {k: list(v) for k, v in REQUIRED_BUFFERS.items()})
    scene: dict = field(default_factory=dict)  # free-form provenance (scene, seed, renderer)

    def __post_init__(self):
        if self.format != FORMAT_NAME:
            raise ValueError(f"format must be '{FORMAT_NAME}', got '{self.format}'")
        if self.version > FORMAT_VERSION:
            raise ValueError(f"dataset format version {self.version} is newer than this toolkit ({FORMAT_VERSION})")
        if isinstance(self.scale, float) and self.scale.is_integer():
            self.scale = int(self.scale)  # 2.0 reads as 2: the integer scale it is
        self.jitter_pattern = current_pattern(self.jitter_pattern)  # a dataset written before a rename reads as today's
        if isinstance(self.scale, float):
            if not (math.isfinite(self.scale) and scales.MIN_SCALE <= self.scale <= scales.MAX_SCALE):
                raise ValueError(f"scale {self.scale} is outside [{scales.MIN_SCALE}, {scales.MAX_SCALE}]")
        mismatch = scales.size_mismatch(self.lr_size, self.hr_size, self.scale)
        if mismatch:
            raise ValueError(mismatch)

    @property
    def ratios(self):
        """The exact ``hr / lr`` of each axis ``(x, y)`` (``ops.scale.Ratio``, reduced; the scale
        itself at an integer scale)."""
        return scales.axis_ratios(self.lr_size, self.hr_size)

    @property
    def frame_count(self) -> int:
        return len(self.frames)


_TOLD_RENAMED: set[str] = set()


def current_pattern(pattern: str) -> str:
    """``pattern`` by today's name: an earlier spelling (``ops.jitter.RENAMED_PATTERNS``, such as
    ``mnss`` for ``grid``) becomes the new one, and logs one deprecation line per process naming it.
    Read by data configs, ``--set jitter=...`` and ``meta.json``; anything else is returned as given."""
    new = jitter_patterns.pattern_name(pattern)
    if new != pattern and pattern not in _TOLD_RENAMED:
        _TOLD_RENAMED.add(pattern)
        log.warning("the jitter pattern '%s' is now called '%s' (the same offsets): '%s' is still read but "
                    "deprecated, write '%s'", pattern, new, pattern, new)
    return new


def key_buffer(key: str) -> tuple[str, str]:
    """The dataset buffer behind a frame key: ``hr_<name>`` is HR ``<name>``, ``lr_<name>`` LR ``<name>``,
    the rest (``color``, ``depth``, ``motion``) LR buffers of that name."""
    for res in ("hr", "lr"):
        if key.startswith(f"{res}_"):
            return res, key[len(res) + 1:]
    return "lr", key


def extra_buffers_of(keys) -> dict[str, list[str]]:
    """``{"hr_buffers": [...], "lr_buffers": [...]}``: the optional buffers frame ``keys`` name (for
    ``dataset.loader.eval_sequences``)."""
    out: dict[str, list[str]] = {"hr_buffers": [], "lr_buffers": []}
    for key in keys:
        res, buffer = key_buffer(key)
        if buffer not in REQUIRED_BUFFERS[res]:
            out[f"{res}_buffers"].append(buffer)
    return out


def buffer_path(seq_dir: str | Path, res: str, buffer: str, index: int) -> Path:
    return Path(seq_dir) / res / buffer / f"{index:05d}.exr"


def write_meta(seq_dir: str | Path, meta: SequenceMeta) -> Path:
    return atomic_write_json(Path(seq_dir) / META_FILE, to_dict(meta))


def read_meta(seq_dir: str | Path) -> SequenceMeta:
    path = Path(seq_dir) / META_FILE
    if not path.is_file():
        raise UserError(f"{seq_dir} is not a dataset sequence (no {META_FILE})")
    return from_dict(SequenceMeta, read_json(path), source=str(path))


def find_sequences(root: str | Path | list) -> list[Path]:
    """A sequence directory itself, or every sequence directly below ``root``, sorted; a list of
    such roots gives their sequences in the list's order."""
    if isinstance(root, (list, tuple)):
        return [seq for r in root for seq in find_sequences(r)]
    root = Path(root)
    if not root.exists():
        raise UserError(f"dataset directory not found: {root}")
    if (root / META_FILE).is_file():
        return [root]
    seqs = sorted(p.parent for p in root.glob(f"*/{META_FILE}") if not p.parent.name.startswith("."))
    if not seqs:
        raise UserError(f"no dataset sequences in {root} (expected {META_FILE} in it or its subdirectories)")
    return seqs


def write_buffer(seq_dir: str | Path, res: str, buffer: str, index: int, image: np.ndarray) -> Path:
    spec = BUFFERS[res][buffer]
    return exr.write_exr(buffer_path(seq_dir, res, buffer, index), image, half=spec.half, channels=spec.channels)


def read_raw_buffer(seq_dir: str | Path, res: str, buffer: str, index: int) -> np.ndarray:
    """``(H, W, C)`` float32 exactly as stored (engine conventions)."""
    if buffer not in BUFFERS.get(res, {}):
        raise UserError(f"unknown buffer '{res}/{buffer}'")
    return exr.read_exr(buffer_path(seq_dir, res, buffer, index), BUFFERS[res][buffer].channels)


def read_buffer(seq_dir: str | Path, meta: SequenceMeta, res: str, buffer: str, index: int) -> np.ndarray:
    """``(H, W, C)`` float32 in canonical conventions (see ``mnss_kit.ops.conventions``)."""
    raw = read_raw_buffer(seq_dir, res, buffer, index)
    size = meta.lr_size if res == "lr" else meta.hr_size
    if raw.shape[:2] != (size[1], size[0]):
        raise UserError(
            f"{buffer_path(seq_dir, res, buffer, index)}: size {raw.shape[1]}x{raw.shape[0]} "
            f"does not match meta {res}_size {size[0]}x{size[1]}"
        )
    if buffer == "depth":
        return canonical_depth(raw, meta)
    if buffer == "motion":
        return canonical_motion(raw, meta, size)
    if buffer in COLOUR_BUFFERS:
        return canonical_colour(raw, meta)
    return raw


def canonical_depth(raw: np.ndarray, meta: SequenceMeta) -> np.ndarray:
    """Stored depth -> linear depth normalised to [0, 1] (0 at near)."""
    n, f = meta.near, meta.far
    if meta.depth_encoding == "hardware":
        z = view_depth(raw, n, f, meta.reverse_z)
    else:
        z = raw.astype(np.float64)
    return np.clip((z - n) / (f - n), 0.0, 1.0).astype(np.float32)


def view_depth(hardware: np.ndarray, near: float, far: float, reverse_z: bool) -> np.ndarray:
    """``(...)`` float64 view depth z of [0, 1] hardware depth; ``far`` may be ``inf`` (infinite projection)."""
    d = hardware.astype(np.float64)
    if reverse_z:
        d = 1.0 - d
    # standard D3D/Vulkan-style [0, 1] hardware depth: d = f (z - n) / (z (f - n)), i.e.
    # z = n / (1 - d (1 - n / f)); with an infinite far plane d = 1 - n / z
    return near / np.maximum(1.0 - d * (1.0 - near / far), 1e-12)


def canonical_motion(raw: np.ndarray, meta: SequenceMeta, size: tuple[int, int]) -> np.ndarray:
    """Stored motion -> pixels of this resolution, +y down, pointing to the previous frame."""
    m = raw[..., :2].astype(np.float32) * np.float32(meta.motion.scale)
    w, h = size
    if meta.motion.units == "uv":
        m = m * np.array([w, h], dtype=np.float32)
    elif meta.motion.units == "ndc":
        m = m * np.array([w / 2.0, h / 2.0], dtype=np.float32)
    if meta.motion.y_axis == "up":
        m[..., 1] = -m[..., 1]
    if meta.motion.points_to == "current":
        m = -m
    return m


def canonical_colour(raw: np.ndarray, meta: SequenceMeta) -> np.ndarray:
    if meta.color_space == "linear_hdr":
        return colour.to_display(raw, meta.exposure)
    return np.clip(raw, 0.0, 1.0).astype(np.float32)


def replace_meta(meta: SequenceMeta, **changes) -> SequenceMeta:
    return dataclasses.replace(meta, **changes)
