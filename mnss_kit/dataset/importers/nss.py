"""Import an Arm Neural Super Sampling capture (spec 1.0.x, the format of Arm's Unreal capture plugin).

    SRC/NNNN.json                          per-sequence metadata, one entry per frame
    SRC/ground_truth/NNNN/FFFF.exr         HR target, RGBA half, linear HDR
    SRC/motion_gt/NNNN/FFFF.exr            HR motion, RG, UV units, unjittered
    SRC/x{ratio}/{color,depth,motion}/NNNN/FFFF.exr   LR buffers per ratio (``2``, ``1_5``, ...)

Every ratio the toolkit takes (an integer >= 2, or a quality mode in [1.25, 4] such as ``1_5`` and
``1_7``: ``ops.scale``) becomes its own dataset, ``OUT/x{ratio}/NNNN/``; a fractional ratio's
``meta.json`` has ``scale`` 1.5 and the LR size ``round_half_up(TargetResolution / s)`` per axis,
which the capture's LR files must have.  The buffers are copied as
stored and their conventions recorded in ``meta.json``: motion in UV pointing to the previous
frame with +y down (FSR2's convention, which NSS follows), hardware depth with the capture's
near and far planes and ``ReverseZ``, linear HDR colour with ``Exposure``.  Two things the
dataset format cannot record are converted once: depth of an infinite (or changing) projection
becomes linear view depth, and an exposure that changes within a sequence is multiplied into
the colour.  Other ratios (x1, or past [1.25, 4]) are checked for presence and reported, not
written.  The models take integer scales only so far (``model.family.INTEGER_SCALE_ONLY``): a
fractional ratio's dataset serves ``data check``, ``eval``'s bicubic and the quality-mode work.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import UserError
from ...fileio import read_json
from ...ops.scale import MAX_SCALE, MIN_SCALE, lr_size_for, parse_scale
from .. import exr
from ..format import FORMAT_NAME, FORMAT_VERSION, FrameMeta, MotionConvention, SequenceMeta, view_depth, write_buffer, write_meta
from .publish import ImportResult, publish

RATIO_DIR = re.compile(r"^x(\d+)(?:_(\d+))?$")
SEQUENCE_FILE = re.compile(r"^\d+\.json$")
INFINITE_FAR = -1.0  # CameraFarPlane of an infinite projection
# Far plane recorded for depth converted from an infinite projection (metres): Arm's NSS trainer
# assumes the same; farther surfaces (the sky) are clipped to it.
INFINITE_FAR_STANDIN = 5000.0
NSS_MOTION = MotionConvention(units="uv", points_to="previous", y_axis="down", scale=1.0)
NUMBER = (int, float)
SEQUENCE_KEYS = {"Version": str, "EmulatedFramerate": NUMBER, "TargetResolution": dict, "Samples": dict,
                 "ReverseZ": bool, "Frames": list}
FRAME_KEYS = {"Frame": int, "FovX": NUMBER, "FovY": NUMBER, "CameraNearPlane": NUMBER, "CameraFarPlane": NUMBER,
              "ViewProjection": list, "Jitter": dict, "NormalizedPerRatioJitter": list}
LR_BUFFERS = {"color": ("R", "G", "B"), "depth": ("R",), "motion": ("R", "G")}


@dataclass(frozen=True)
class Ratio:
    name: str  # as in the folder name: "2", "1_5"

    @property
    def value(self) -> float:
        return float(self.name.replace("_", "."))

    @property
    def trainable(self) -> bool:  # the dataset format takes an integer scale >= 2 or one in [1.25, 4]
        if "_" not in self.name:
            return int(self.name) >= 2
        return MIN_SCALE <= self.value <= MAX_SCALE

    @property
    def scale(self) -> int | float:
        """The dataset's ``scale``: an int for an integer ratio, else the ratio as written (1.5)."""
        return int(self.name) if "_" not in self.name else parse_scale(self.value)


def import_nss(src: str | Path, out: str | Path, overwrite: bool = False) -> ImportResult:
    """Import every sequence and integer ratio of the capture ``src`` into ``out`` (atomically)."""
    src = Path(src)
    if not src.is_dir():
        raise UserError(f"NSS capture not found: {src} is not a directory")
    ratios = find_ratios(src)
    sequences = {path.stem: read_sequence(path) for path in sorted(src.glob("*.json")) if SEQUENCE_FILE.match(path.name)}
    if not sequences:
        raise UserError(f"{src}: no sequence metadata (NNNN.json) in the NSS capture")
    trainable = [r for r in ratios if r.trainable]
    notes = [_untrainable_note(src, r, sequences) for r in ratios if not r.trainable]
    if not trainable:
        raise UserError(f"{src}: no upscaling ratio of 2 or more or in [{MIN_SCALE}, {MAX_SCALE}] "
                        f"(found {', '.join('x' + r.name for r in ratios)})")

    written = []  # frames written per sequence and ratio

    def write(staging: Path) -> list[Path]:
        for ratio in trainable:
            for name, data in sequences.items():
                count, note = write_sequence(src, name, data, ratio, len(ratios), staging / f"x{ratio.name}" / name)
                written.append(count)
                notes.extend([note] if note else [])
        return [staging / f"x{r.name}" for r in trainable]

    warnings = publish(out, write, overwrite)
    return ImportResult([str(Path(out) / f"x{r.name}") for r in trainable], len(sequences), sum(written), notes, warnings)


def _untrainable_note(src: Path, ratio: Ratio, sequences: dict[str, dict]) -> str:
    """What a fractional ratio (or x1) holds, its frame files counted against ``Frames``, and why it is not written."""
    frames = 0
    for name, data in sequences.items():
        folders = [src / f"x{ratio.name}" / buffer / name for buffer in LR_BUFFERS]
        frames += len(_present_frames(folders, len(data["Frames"]), data["_path"])[0][folders[0]])
    why = "does not upscale" if ratio.value <= 1 else f"is outside [{MIN_SCALE}, {MAX_SCALE}]"
    return (f"x{ratio.name}: {frames} frames found, not imported: ratio {ratio.value:g} {why} "
            "(the toolkit takes an integer scale of 2 or more, or a quality mode in that range)")


def find_ratios(src: Path) -> list[Ratio]:
    ratios = sorted((Ratio(p.name[1:]) for p in src.iterdir() if p.is_dir() and RATIO_DIR.match(p.name)),
                    key=lambda r: r.value, reverse=True)
    if not ratios:
        raise UserError(f"{src}: no x{{ratio}} folder (x2, x1_5, ...) in the NSS capture")
    return ratios


def read_sequence(path: Path) -> dict:
    """The sequence's JSON with its mandatory keys and types checked (UserError naming file and key)."""
    data = read_json(path)
    _require(data, SEQUENCE_KEYS, f"{path}")
    if not str(data["Version"]).startswith("1."):
        raise UserError(f"{path}: Version {data['Version']!r}: only NSS capture spec 1.x is read")
    _require(data["TargetResolution"], {"X": int, "Y": int}, f"{path}: TargetResolution")
    if not data["Frames"]:
        raise UserError(f"{path}: Frames is empty")
    for i, frame in enumerate(data["Frames"]):
        _require(frame, FRAME_KEYS, f"{path}: Frames[{i}]")
    if data.get("GTColorSpace", "Linear") != "Linear":
        raise UserError(f"{path}: GTColorSpace {data['GTColorSpace']!r}: only linear HDR captures are read")
    return data | {"_path": str(path)}


def _require(obj, keys: dict, where: str) -> None:
    if not isinstance(obj, dict):
        raise UserError(f"{where}: must be a JSON object, got {type(obj).__name__}")
    for key, types in keys.items():
        if key not in obj:
            raise UserError(f"{where}: missing key '{key}'")
        value = obj[key]
        if isinstance(value, bool) and bool not in (types if isinstance(types, tuple) else (types,)):
            raise UserError(f"{where}: '{key}' has the wrong type (bool)")
        if not isinstance(value, types):
            raise UserError(f"{where}: '{key}' must be {_type_name(types)}, got {type(value).__name__}")


def _type_name(types) -> str:
    return "a number" if types == NUMBER else {str: "a string", bool: "true or false", int: "an integer",
                                               dict: "an object", list: "a list"}[types]


def write_sequence(src: Path, name: str, data: dict, ratio: Ratio, ratio_count: int, dest: Path) -> tuple[int, str | None]:
    """Write sequence ``name`` at ``ratio`` as one dataset sequence in ``dest``: the frames every
    buffer has files for.  Returns their count and a warning when ``Frames`` lists more."""
    where = data["_path"]
    scale = ratio.scale
    hr_size = (data["TargetResolution"]["X"], data["TargetResolution"]["Y"])
    if isinstance(scale, int):
        if hr_size[0] % scale or hr_size[1] % scale:
            raise UserError(f"{where}: TargetResolution {hr_size[0]}x{hr_size[1]} is not divisible by ratio {scale}")
        lr_size = (hr_size[0] // scale, hr_size[1] // scale)
    else:  # the display size is given, the render size derived (round half up per axis, as ops.scale)
        lr_size = lr_size_for(hr_size, scale)
    folders = {b: src / f"x{ratio.name}" / b / name for b in LR_BUFFERS}
    folders |= {b: src / b / name for b in ("ground_truth", "motion_gt")}
    present, missing_note = _present_frames(list(folders.values()), len(data["Frames"]), where)
    files = {b: present[folder] for b, folder in folders.items()}
    frames = data["Frames"][:len(files["color"])]
    depth = DepthPlan.of(frames, data["ReverseZ"], where)
    exposure = [float(f.get("Exposure", 1.0)) for f in frames]
    if not all(e > 0 for e in exposure):
        raise UserError(f"{where}: Exposure must be > 0 (got {min(exposure)})")
    baked = len(set(exposure)) > 1  # the format holds one exposure per sequence: bake a changing one
    jitter_index = _jitter_index(data, ratio, ratio_count)
    metas = []
    for i, frame in enumerate(frames):
        factor = np.float32(exposure[i] if baked else 1.0)
        lr = {b: _read(files[b][i], LR_BUFFERS[b], lr_size) for b in LR_BUFFERS}
        write_buffer(dest, "lr", "color", i, lr["color"] * factor)
        write_buffer(dest, "lr", "depth", i, depth.convert(lr["depth"], frame))
        write_buffer(dest, "lr", "motion", i, lr["motion"])
        write_buffer(dest, "hr", "reference", i, _read(files["ground_truth"][i], ("R", "G", "B"), hr_size) * factor)
        write_buffer(dest, "hr", "motion", i, _read(files["motion_gt"][i], ("R", "G"), hr_size))
        metas.append(FrameMeta(index=i, jitter=_jitter(frame, jitter_index, lr_size, f"{where}: Frames[{i}]"),
                               reset=i == 0 or bool(frame.get("CameraCut", False)),
                               time=i / float(data["EmulatedFramerate"])))
    write_meta(dest, SequenceMeta(
        format=FORMAT_NAME, version=FORMAT_VERSION, name=name, scale=scale, lr_size=lr_size, hr_size=hr_size,
        jitter_pattern=str(data["Samples"].get("Sequence", "nss")), frames=metas,
        near=depth.near, far=depth.far, reverse_z=depth.reverse_z, depth_encoding=depth.encoding, motion=NSS_MOTION,
        color_space="linear_hdr", exposure=1.0 if baked else exposure[0],
        buffers={"lr": list(LR_BUFFERS), "hr": ["reference", "motion"]},
        scene={"importer": "nss", "source": str(src), "nss_version": data["Version"], "ratio": f"x{ratio.name}",
               "samples": data["Samples"], "emulated_framerate": data["EmulatedFramerate"],
               "exposure_baked_into_colour": baked, "depth_converted_to_linear": depth.encoding == "linear",
               "frames_listed": len(data["Frames"])},
    ))
    return len(frames), missing_note


def _frame_files(folder: Path, count: int, where: str) -> list[Path]:
    """The frame files of one buffer, in name order (paired with ``Frames`` by position, as Arm's reader does)."""
    if not folder.is_dir():
        raise UserError(f"missing folder {folder} (the capture's buffers for {where})")
    files = sorted(p for p in folder.glob("*.exr") if not p.name.startswith("."))
    if len(files) > count:
        raise UserError(f"{folder}: {len(files)} frame file(s), but {where} lists {count} frames")
    if not files:
        raise UserError(f"{folder}: no frame files (.exr), but {where} lists {count} frames")
    return files


def _present_frames(folders: list[Path], count: int, where: str) -> tuple[dict[Path, list[Path]], str | None]:
    """The first frames every buffer folder has files for, paired by position as Arm's reader does
    (Arm's sample captures ship fewer frame files than ``Frames`` lists), and a warning counting the
    frames left out; ``UserError`` if the folders' first files do not carry the same names (a file
    missing in the middle would pair the rest with the wrong frames)."""
    files = {folder: _frame_files(folder, count, where) for folder in folders}
    n = min(len(f) for f in files.values())
    first = folders[0]
    for folder in folders[1:]:
        names, expected = [p.name for p in files[folder][:n]], [p.name for p in files[first][:n]]
        if names != expected:
            odd = next(a for a, b in zip(names, expected) if a != b)
            raise UserError(f"{folder}: frame file {odd} where {first} has {expected[names.index(odd)]} "
                            "(a frame file missing; files pair with Frames by position)")
    present = {folder: f[:n] for folder, f in files.items()}
    if n == count:
        return present, None
    short = min(files, key=lambda f: len(files[f]))
    return present, (f"warning: {short}: frame files for {n} of the {count} frames {Path(where).name} lists "
                     f"({count - n} missing); imported frames 0..{n - 1}, as Arm's reader does")


def _read(path: Path, channels: tuple[str, ...], size: tuple[int, int]) -> np.ndarray:
    image = exr.read_exr(path, channels)
    if image.shape[:2] != (size[1], size[0]):
        raise UserError(f"{path}: size {image.shape[1]}x{image.shape[0]}, expected {size[0]}x{size[1]}")
    return image


def _jitter_index(data: dict, ratio: Ratio, ratio_count: int) -> int:
    indices = data.get("UpscalingRatiosIndices")
    key = f"x{ratio.name}_index"
    if indices is None and ratio_count == 1:
        return 0
    if not isinstance(indices, dict) or not isinstance(indices.get(key), int):
        raise UserError(f"{data['_path']}: UpscalingRatiosIndices needs an integer '{key}' (the capture has several ratios)")
    return indices[key]


def _jitter(frame: dict, index: int, lr_size: tuple[int, int], where: str) -> tuple[float, float]:
    """``NormalizedPerRatioJitter`` (jitter / LR size, the UV offset added to the pixel centre) in LR pixels."""
    table = frame["NormalizedPerRatioJitter"]
    if index >= len(table):
        raise UserError(f"{where}: NormalizedPerRatioJitter has {len(table)} entries, no index {index}")
    entry = table[index]
    _require(entry, {"X": NUMBER, "Y": NUMBER}, f"{where}: NormalizedPerRatioJitter[{index}]")
    return float(entry["X"]) * lr_size[0], float(entry["Y"]) * lr_size[1]


@dataclass(frozen=True)
class DepthPlan:
    """How a sequence's depth is written: as stored (hardware, one pair of planes) or as linear view depth."""

    encoding: str  # "hardware" or "linear"
    near: float
    far: float
    reverse_z: bool

    @staticmethod
    def of(frames: list[dict], reverse_z: bool, where: str) -> "DepthPlan":
        planes = {(float(f["CameraNearPlane"]), float(f["CameraFarPlane"])) for f in frames}
        near = min(n for n, _ in planes)
        if near <= 0:
            raise UserError(f"{where}: CameraNearPlane must be > 0 metres, got {near}")
        if len(planes) == 1 and next(iter(planes))[1] != INFINITE_FAR:
            return DepthPlan("hardware", near, next(iter(planes))[1], reverse_z)
        far = max(INFINITE_FAR_STANDIN if f == INFINITE_FAR else f for _, f in planes)
        return DepthPlan("linear", near, far, reverse_z)

    def convert(self, depth: np.ndarray, frame: dict) -> np.ndarray:
        if self.encoding == "hardware":
            return depth
        far = float(frame["CameraFarPlane"])
        z = view_depth(depth, float(frame["CameraNearPlane"]), np.inf if far == INFINITE_FAR else far, self.reverse_z)
        return np.minimum(z, self.far).astype(np.float32)
