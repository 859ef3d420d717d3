"""Import a folder of per-buffer image files (PNG 8/16-bit, OpenEXR, NPY) described by a mapping YAML.

The mapping names, per toolkit buffer (``lr/color``, ``lr/depth``, ``lr/motion``, ``hr/reference``,
optional G-buffers), a file pattern relative to a sequence folder (``lr/color/{frame:04d}.png``),
a decode rule that turns the stored numbers into the values the engine meant, and the
conventions of those values (motion units and sign, depth encoding, colour space), which are
recorded in ``meta.json`` as they are: ``read_buffer`` converts them once, when the data is read.
``mnss_kit/configs/import/packed8.yaml`` is the mapping of the packed 8-bit captures of public
mobile-upscaler datasets.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from ...config import load_config, resolve_config_path
from ...errors import UserError
from ...ops.jitter import PATTERNS, jitter_sequence
from ...ops.scale import hr_size_for, lr_size_for, parse_scale
from ..format import (BUFFERS, current_pattern, COLOUR_BUFFERS, FORMAT_NAME, FORMAT_VERSION, REQUIRED_BUFFERS, FrameMeta, MotionConvention, SequenceMeta,
                      write_buffer, write_meta)
from .imagefiles import read_image
from .publish import ImportResult, publish

FRAME_FIELD = re.compile(r"\{frame(?::[^}]*)?\}")
PACKED_BASE = 255.0  # two 16-bit numbers per RGBA8 pixel: u = R/255 + G/255^2, v = B/255 + A/255^2
MOTION_KEYS = ("units", "points_to", "y_axis", "scale")
DEPTH_KEYS = ("encoding", "reverse_z")
COLOUR_KEYS = ("space",)
# buffers whose conventions meta.json records once for both: the first one's mapping sets them
SHARED_CONVENTIONS = {("lr/color", "hr/reference"): COLOUR_KEYS, ("lr/motion", "hr/motion"): MOTION_KEYS,
                      ("lr/depth", "hr/depth"): DEPTH_KEYS}


@dataclass
class BufferMapping:
    file: str  # relative to the sequence folder, with one {frame} field (Python format, e.g. {frame:04d})
    decode: str = "unorm"  # a key of DECODE_RULES
    # motion buffers: the stored convention (docs/dataset.md, Motion vectors)
    units: Literal["pixels", "uv", "ndc"] | None = None
    points_to: Literal["previous", "current"] | None = None
    y_axis: Literal["down", "up"] | None = None
    scale: float | None = None
    # depth buffers
    encoding: Literal["hardware", "linear"] | None = None
    reverse_z: bool | None = None
    # colour and reference
    space: Literal["linear_hdr", "display"] | None = None


@dataclass
class JitterMapping:
    pattern: str = "custom"  # the toolkit pattern the capture used (offsets generated when there is no file)
    file: str | None = None  # per sequence folder: one row "x y" per frame (.txt or .npy)
    units: Literal["lr_pixels", "uv"] = "lr_pixels"  # uv: offsets divided by the LR size
    sign: Literal[1, -1] = 1  # -1 when the file holds the projection offset, not the sample position


@dataclass
class ImageMapping:
    scale: int | float  # an integer >= 2, or a quality mode in [1.25, 4] (1.5, 1.7: ops.scale; lr = round(hr / s))
    buffers: dict[str, BufferMapping]  # "lr/color", "hr/reference", ...
    jitter: JitterMapping = field(default_factory=JitterMapping)
    sequences: str = "."  # glob of sequence folders under SRC; "." when SRC is one sequence
    cuts: str | None = None  # per sequence folder: a text file of the frame numbers that follow a camera cut
    near: float = 0.1
    far: float = 1000.0
    exposure: float = 1.0
    fps: float = 30.0
    scene: dict = field(default_factory=dict)  # free-form provenance, copied into meta.json


def _unorm(stored: np.ndarray, path: Path) -> np.ndarray:
    """Integers to [0, 1] by their bit depth (8-bit / 255, 16-bit / 65535); floats as stored."""
    if stored.dtype.kind == "f":
        return stored.astype(np.float32)
    return (stored.astype(np.float64) / np.iinfo(stored.dtype).max).astype(np.float32)


def _raw(stored: np.ndarray, path: Path) -> np.ndarray:
    return stored.astype(np.float32)


def _packed_pair(stored: np.ndarray, path: Path) -> np.ndarray:
    """RGBA8 holding two base-255 numbers u, v in [0, 1) -> ``(2u - 1, 2v - 1)``, a full screen spanning 2."""
    if stored.dtype != np.uint8 or stored.shape[2] != 4:
        raise UserError(f"{path}: decode rgba8_pair needs an 8-bit RGBA image, got {stored.dtype} with {stored.shape[2]} channel(s)")
    c = stored.astype(np.float64)
    u = c[..., 0] / PACKED_BASE + c[..., 1] / PACKED_BASE**2
    v = c[..., 2] / PACKED_BASE + c[..., 3] / PACKED_BASE**2
    return np.stack([2.0 * u - 1.0, 2.0 * v - 1.0], axis=-1).astype(np.float32)


DECODE_RULES = {"unorm": _unorm, "raw": _raw, "rgba8_pair": _packed_pair}


def load_mapping(name_or_path: str) -> ImageMapping:
    path = resolve_config_path(name_or_path, "import")
    mapping = load_config(ImageMapping, path)
    for key, buf in mapping.buffers.items():
        _check_buffer(key, buf, str(path))
    for res, names in REQUIRED_BUFFERS.items():
        for name in names:
            if f"{res}/{name}" not in mapping.buffers:
                raise UserError(f"{path}: buffers has no '{res}/{name}' (required: lr/color, lr/depth, lr/motion, hr/reference)")
    for pair, keys in SHARED_CONVENTIONS.items():
        _same(mapping.buffers, pair, keys, str(path))
    mapping.jitter.pattern = current_pattern(mapping.jitter.pattern)  # an earlier spelling (mnss) as today's
    if mapping.jitter.file is None and mapping.jitter.pattern not in PATTERNS:
        raise UserError(f"{path}: jitter needs a file, or a pattern the offsets are generated from ({', '.join(PATTERNS)})")
    if mapping.scale < 2 and float(mapping.scale).is_integer():
        raise UserError(f"{path}: scale must be an integer >= 2 or a quality mode in [1.25, 4], got {mapping.scale}")
    mapping.scale = parse_scale(mapping.scale, f"{path}: scale")  # 2, 3, 4 or in [1.25, 4]; 2.0 -> 2
    return mapping


def _check_buffer(key: str, buf: BufferMapping, source: str) -> None:
    res, _, name = key.partition("/")
    if name not in BUFFERS.get(res, {}):
        known = ", ".join(f"{r}/{b}" for r in BUFFERS for b in BUFFERS[r])
        raise UserError(f"{source}: unknown buffer '{key}' (known: {known})")
    if buf.decode not in DECODE_RULES:
        raise UserError(f"{source}: buffers.{key}.decode: unknown decode rule '{buf.decode}' (known: {', '.join(DECODE_RULES)})")
    if len(FRAME_FIELD.findall(buf.file)) != 1:
        raise UserError(f"{source}: buffers.{key}.file must hold one {{frame}} field, got '{buf.file}'")
    allowed = MOTION_KEYS if name == "motion" else DEPTH_KEYS if name == "depth" else COLOUR_KEYS if name in COLOUR_BUFFERS else ()
    for k in MOTION_KEYS + DEPTH_KEYS + COLOUR_KEYS:
        if getattr(buf, k) is not None and k not in allowed:
            raise UserError(f"{source}: buffers.{key}.{k} does not apply to a {name} buffer")


def import_images(src: str | Path, mapping_name: str, out: str | Path, overwrite: bool = False) -> ImportResult:
    """Import every sequence folder of ``src`` that ``mapping`` describes into ``out`` (atomically)."""
    src = Path(src)
    if not src.is_dir():
        raise UserError(f"capture not found: {src} is not a directory")
    mapping = load_mapping(mapping_name)
    folders = [src] if mapping.sequences == "." else sorted(p for p in src.glob(mapping.sequences) if p.is_dir())
    if not folders:
        raise UserError(f"{src}: no sequence folder matches '{mapping.sequences}'")
    frame_lists = {folder: frame_numbers(folder, mapping.buffers["lr/color"].file) for folder in folders}

    def write(staging: Path) -> list[Path]:
        for folder, numbers in frame_lists.items():
            write_sequence(folder, numbers, mapping, staging / folder.name)
        return [staging]

    warnings = publish(out, write, overwrite)
    return ImportResult([str(out)], len(folders), sum(map(len, frame_lists.values())), [], warnings)


def frame_numbers(folder: Path, pattern: str) -> list[int]:
    """The frame numbers of the files matching ``pattern`` in ``folder``: consecutive, from the smallest."""
    before, after = FRAME_FIELD.split(pattern)
    regex = re.compile(re.escape(before) + r"(\d+)" + re.escape(after) + "$")
    numbers = sorted(int(m.group(1)) for p in folder.glob(FRAME_FIELD.sub("*", pattern))
                     if (m := regex.match(p.relative_to(folder).as_posix())))
    if not numbers:
        raise UserError(f"{folder}: no file matches '{pattern}'")
    gaps = [n for n, m in zip(numbers, numbers[1:]) if m != n + 1]
    if gaps:
        raise UserError(f"{folder / pattern.format(frame=gaps[0] + 1)}: missing frame (frames must be consecutive)")
    return numbers


def write_sequence(folder: Path, numbers: list[int], mapping: ImageMapping, dest: Path) -> None:
    lr_size = hr_size = None
    keys = sorted(mapping.buffers, key=lambda k: k != "lr/color")  # lr/color first: it sets the LR size
    for i, number in enumerate(numbers):
        for key in keys:
            res, _, name = key.partition("/")
            buf = mapping.buffers[key]
            path = folder / buf.file.format(frame=number)
            image = decode(path, buf, len(BUFFERS[res][name].channels))
            lr_size = lr_size or (image.shape[1], image.shape[0])
            if isinstance(mapping.scale, int):
                _check_size(path, image, res, lr_size, mapping.scale)
            else:  # the first HR file sets the display size; lr = round_half_up(hr / s) per axis
                hr_size = hr_size or (_check_fractional_size(path, image, lr_size, mapping.scale) if res == "hr" else None)
                if (image.shape[1], image.shape[0]) != (hr_size if res == "hr" else lr_size):
                    ew, eh = hr_size if res == "hr" else lr_size
                    raise UserError(f"{path}: size {image.shape[1]}x{image.shape[0]}, expected {ew}x{eh} "
                                    f"(the size of {'the first HR file' if res == 'hr' else 'lr/color'})")
            write_buffer(dest, res, name, i, image)
    write_meta(dest, sequence_meta(folder, numbers, mapping, lr_size, hr_size))


def _check_fractional_size(path: Path, image: np.ndarray, lr_size: tuple[int, int], scale: float) -> tuple[int, int]:
    """The HR size of ``image`` when it belongs to ``lr_size`` at the fractional ``scale``."""
    hr_size = (image.shape[1], image.shape[0])
    if lr_size_for(hr_size, scale) != tuple(lr_size):
        ew, eh = lr_size_for(hr_size, scale)
        raise UserError(f"{path}: size {hr_size[0]}x{hr_size[1]} at scale {scale} gives LR {ew}x{eh} "
                        f"(round(hr / s), half up), but lr/color is {lr_size[0]}x{lr_size[1]}")
    return hr_size


def decode(path: Path, buf: BufferMapping, channels: int) -> np.ndarray:
    """``(H, W, channels)`` float32 values of one file by the buffer's decode rule."""
    image = DECODE_RULES[buf.decode](read_image(path), path)
    if image.shape[2] < channels:
        raise UserError(f"{path}: {image.shape[2]} channel(s) after decode '{buf.decode}', the buffer needs {channels}")
    return image[..., :channels]


def _check_size(path: Path, image: np.ndarray, res: str, lr_size: tuple[int, int], scale: int) -> None:
    w, h = image.shape[1], image.shape[0]
    if res == "hr" and (w % scale or h % scale):
        raise UserError(f"{path}: size {w}x{h} is not divisible by scale {scale}")
    ew, eh = (lr_size[0] * scale, lr_size[1] * scale) if res == "hr" else lr_size
    if (w, h) != (ew, eh):
        what = f"scale {scale} x the LR size {lr_size[0]}x{lr_size[1]}" if res == "hr" else "the size of lr/color"
        raise UserError(f"{path}: size {w}x{h}, expected {ew}x{eh} ({what})")


def sequence_meta(folder: Path, numbers: list[int], mapping: ImageMapping, lr_size: tuple[int, int],
                  hr_size: tuple[int, int] | None = None) -> SequenceMeta:
    buffers = mapping.buffers
    colour, depth, motion = buffers["lr/color"], buffers["lr/depth"], buffers["lr/motion"]
    jitter = read_jitter(folder, numbers, mapping, lr_size)
    cuts = read_cuts(folder, mapping)
    scale = mapping.scale
    return SequenceMeta(
        format=FORMAT_NAME, version=FORMAT_VERSION, name=folder.name, scale=scale, lr_size=lr_size,
        hr_size=hr_size or hr_size_for(lr_size, scale), jitter_pattern=mapping.jitter.pattern,
        frames=[FrameMeta(index=i, jitter=(float(jitter[i, 0]), float(jitter[i, 1])), reset=i == 0 or n in cuts,
                          time=i / mapping.fps) for i, n in enumerate(numbers)],
        near=mapping.near, far=mapping.far, reverse_z=bool(depth.reverse_z), depth_encoding=depth.encoding or "hardware",
        motion=MotionConvention(units=motion.units or "pixels", points_to=motion.points_to or "previous",
                                y_axis=motion.y_axis or "down", scale=1.0 if motion.scale is None else motion.scale),
        color_space=colour.space or "linear_hdr", exposure=mapping.exposure,
        buffers={res: [k.partition("/")[2] for k in buffers if k.startswith(res + "/")] for res in ("lr", "hr")},
        scene={**mapping.scene, "importer": "images", "source": str(folder), "first_frame": numbers[0]},
    )


def _same(buffers: dict[str, BufferMapping], pair: tuple[str, str], keys: tuple[str, ...], source: str) -> None:
    """The LR and HR buffer of one kind share one convention in meta.json."""
    a, b = (buffers.get(k) for k in pair)
    if b is None:
        return
    for k in keys:
        if getattr(b, k) is not None and getattr(b, k) != getattr(a, k):
            raise UserError(f"{source}: buffers.{pair[1]}.{k} must equal buffers.{pair[0]}.{k} "
                            "(meta.json records one convention for both)")


def read_jitter(folder: Path, numbers: list[int], mapping: ImageMapping, lr_size: tuple[int, int]) -> np.ndarray:
    """``(frames, 2)`` float64 jitter in LR pixels."""
    spec = mapping.jitter
    if spec.file is None:
        return jitter_sequence(spec.pattern, mapping.scale, len(numbers)).astype(np.float64)
    path = folder / spec.file
    values = _read_table(path)
    if values.ndim != 2 or values.shape[1] != 2 or len(values) < len(numbers):
        raise UserError(f"{path}: expected one row 'x y' per frame ({len(numbers)} frames), got shape {values.shape}")
    values = values[: len(numbers)] * spec.sign
    return values * np.array(lr_size, np.float64) if spec.units == "uv" else values


def read_cuts(folder: Path, mapping: ImageMapping) -> set[int]:
    if mapping.cuts is None or not (folder / mapping.cuts).is_file():  # a sequence without cuts may have no file
        return set()
    values = _read_table(folder / mapping.cuts).ravel()
    if not np.all(values == np.round(values)):
        raise UserError(f"{folder / mapping.cuts}: frame numbers must be integers")
    return {int(v) for v in values}


def _read_table(path: Path) -> np.ndarray:
    if not path.is_file():
        raise UserError(f"missing file: {path}")
    try:
        return np.load(path).astype(np.float64) if path.suffix == ".npy" else np.loadtxt(path, ndmin=2, dtype=np.float64)
    except ValueError as e:
        raise UserError(f"cannot read {path}: {e}") from None
