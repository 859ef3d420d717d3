"""Tensor dumps: every named tensor of every frame, written by the emulator and by a device self-test.

A dump is a directory with ``index.json`` and the frames' arrays (``docs/emulator.md`` is the
format's description for a device-side writer)::

    index.json         {"format": "mnss-kit-dump", "version": 1,
                        "tensors": [{"name", "dtype", "shape", "scale"?, "zero_point"?, "stage"?}, ...],
                        "frames":  [{"index": 0, "file": "frame_00000.npz"}, ...]}
    frame_00000.npz    one array per tensor name (+ "__index__": the tensor entries as JSON bytes)

``tensors`` lists tensors in execution order.  Instead of one ``.npz`` a frame may list a file
per tensor: ``{"index": 0, "files": {"name": "frame_00000/name.bin", ...}}`` with ``.npy``
files or raw little-endian ``.bin`` files (C order; dtype and shape from the tensor entry, or
from an object ``{"file", "dtype", "shape", "scale", "zero_point"}`` in place of the path).
Quantized tensors are stored as integers with ``real = scale * (q - zero_point)``.

A bundle directory reads as a dump too: its golden frames (``golden/``), with the packed NPU
input and output under their tensor names in ``npu.tflite``.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..fileio import atomic_write_bytes, atomic_write_json, check_format, read_json

FORMAT = "mnss-kit-dump"
VERSION = 1
INDEX = "index.json"
NPZ_INDEX_KEY = "__index__"
BUNDLE_MANIFEST = "manifest.json"
DTYPES = ("int8", "uint8", "int16", "uint16", "int32", "float16", "float32", "float64", "bool")


@dataclass
class TensorEntry:
    """What a dump says about one tensor.  ``scale``/``zero_point`` only for quantized tensors."""

    name: str
    dtype: str
    shape: list[int]
    scale: float | None = None
    zero_point: int | None = None
    stage: str | None = None

    def to_json(self) -> dict:
        out = {"name": self.name, "dtype": self.dtype, "shape": list(self.shape)}
        if self.scale is not None:
            out["scale"], out["zero_point"] = float(self.scale), int(self.zero_point or 0)
        if self.stage is not None:
            out["stage"] = self.stage
        return out

    @classmethod
    def from_json(cls, data, where: str) -> "TensorEntry":
        if not isinstance(data, dict) or not isinstance(data.get("name"), str):
            raise UserError(f"{where}: each tensor entry needs a 'name'")
        dtype = data.get("dtype")
        if dtype is not None and dtype not in DTYPES:
            raise UserError(f"{where}: tensor '{data['name']}' has unknown dtype {dtype!r} (one of: {', '.join(DTYPES)})")
        scale = data.get("scale")
        zp = data.get("zero_point", 0 if scale is not None else None)
        return cls(data["name"], dtype or "", [int(d) for d in data.get("shape", [])],
                   None if scale is None else float(scale), None if zp is None else int(zp), data.get("stage"))


def merge_order(known: list[str], frame_order: list[str]) -> list[str]:
    """``known`` names with those of ``frame_order`` added, each right after its predecessor there.

    Frames may skip tensors (a reset frame has no warped history): merging keeps every tensor at
    its place in execution order whichever frame shows it first.
    """
    merged = list(known)
    previous = None
    for name in frame_order:
        if name not in merged:
            merged.insert(merged.index(previous) + 1 if previous is not None else 0, name)
        previous = name
    return merged


def entry_for(name: str, array: np.ndarray, qparams: tuple[float, int] | None = None, stage: str | None = None) -> TensorEntry:
    scale, zp = (None, None) if qparams is None else (float(qparams[0]), int(qparams[1]))
    return TensorEntry(name, np.asarray(array).dtype.name, list(np.shape(array)), scale, zp, stage)


class DumpWriter:
    """Writes a dump frame by frame; the index is rewritten after every frame (atomically)."""

    def __init__(self, directory: str | Path, info: dict | None = None):
        self.dir = Path(directory)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.info = dict(info or {})
        self.tensors: dict[str, TensorEntry] = {}
        self.frames: list[dict] = []

    def write_frame(self, index: int, arrays: dict[str, np.ndarray], entries: dict[str, TensorEntry]) -> Path:
        """One frame: ``arrays`` by name in execution order, ``entries`` their descriptions."""
        order = merge_order(list(self.tensors), list(arrays))
        self.tensors = {n: self.tensors.get(n) or entries[n] for n in order}
        buffer = io.BytesIO()
        index_bytes = np.frombuffer(json.dumps([entries[n].to_json() for n in arrays]).encode(), dtype=np.uint8)
        np.savez(buffer, **{NPZ_INDEX_KEY: index_bytes}, **{n: np.asarray(a) for n, a in arrays.items()})
        name = f"frame_{index:05d}.npz"
        path = atomic_write_bytes(self.dir / name, buffer.getvalue())
        self.frames.append({"index": int(index), "file": name})
        atomic_write_json(self.dir / INDEX, {"format": FORMAT, "version": VERSION, **self.info,
                                             "tensors": [t.to_json() for t in self.tensors.values()],
                                             "frames": self.frames})
        return path


@dataclass
class Dump:
    """A dump opened for reading: tensor entries in execution order, frames by index."""

    root: Path
    tensors: dict[str, TensorEntry]
    frames: dict[int, dict]
    info: dict = field(default_factory=dict)

    def frame(self, index: int) -> dict[str, tuple[np.ndarray, TensorEntry]]:
        """Arrays of one frame with their entries (per-file overrides applied)."""
        spec = self.frames[index]
        where = f"{self.root / INDEX}: frame {index}"
        if "file" in spec:
            return self._npz(self.root / spec["file"])
        files = spec.get("files")
        if not isinstance(files, dict):
            raise UserError(f"{where}: needs 'file' (an .npz) or 'files' (tensor name -> file)")
        return {name: self._one(name, value, where) for name, value in files.items()}

    def _npz(self, path: Path) -> dict[str, tuple[np.ndarray, TensorEntry]]:
        if not path.is_file():
            raise UserError(f"{path}: missing (listed in {INDEX})")
        try:
            with np.load(path, allow_pickle=False) as npz:
                arrays = {k: npz[k] for k in npz.files}
        except Exception as e:  # zipfile / numpy format errors
            raise UserError(f"{path}: not a readable .npz ({type(e).__name__})") from None
        inline = {}
        if NPZ_INDEX_KEY in arrays:
            for item in json.loads(arrays.pop(NPZ_INDEX_KEY).tobytes().decode()):
                inline[item["name"]] = TensorEntry.from_json(item, str(path))
        out = {}
        for name, array in arrays.items():
            entry = self.tensors.get(name) or inline.get(name) or entry_for(name, array)
            out[name] = (array, _described(entry, array))
        return out

    def _one(self, name: str, value, where: str) -> tuple[np.ndarray, TensorEntry]:
        entry = self.tensors.get(name)
        if isinstance(value, dict):
            base = entry.to_json() if entry else {"name": name}
            entry = TensorEntry.from_json({**base, **value, "name": name}, where)
            value = value.get("file")
        if not isinstance(value, str):
            raise UserError(f"{where}: tensor '{name}' has no file")
        path = self.root / value
        if not path.is_file():
            raise UserError(f"{path}: missing (tensor '{name}' of {where})")
        if path.suffix == ".npy":
            try:
                array = np.load(path, allow_pickle=False)
            except Exception as e:
                raise UserError(f"{path}: not a readable .npy ({type(e).__name__})") from None
            return array, _described(entry or entry_for(name, array), array)
        if entry is None or not entry.dtype or not entry.shape:
            raise UserError(f"{path}: raw tensor '{name}' needs dtype and shape in {INDEX}")
        dtype = np.dtype(entry.dtype).newbyteorder("<")
        raw = path.read_bytes()
        expected = int(np.prod(entry.shape)) * dtype.itemsize
        if len(raw) != expected:
            raise UserError(f"{path}: {len(raw)} bytes, tensor '{name}' {entry.dtype} {entry.shape} needs {expected}")
        return np.frombuffer(raw, dtype=dtype).astype(entry.dtype).reshape(entry.shape), entry


def _described(entry: TensorEntry, array: np.ndarray) -> TensorEntry:
    """``entry`` with the dtype and shape the stored array really has."""
    return TensorEntry(entry.name, array.dtype.name, list(array.shape), entry.scale, entry.zero_point, entry.stage)


def read_dump(directory: str | Path) -> Dump:
    """Open a dump directory (or its ``index.json``); ``UserError`` naming the file on any problem."""
    root = Path(directory)
    if root.is_file() and root.name == INDEX:
        root = root.parent
    path = root / INDEX
    if not root.is_dir():
        raise UserError(f"dump directory not found: {root}")
    if not path.is_file() and (root / BUNDLE_MANIFEST).is_file():
        return golden_dump(root)
    if not path.is_file():
        raise UserError(f"{path}: missing (not a tensor dump)")
    data = read_json(path)
    check_format(data, path, FORMAT, "version", VERSION, "a tensor dump")
    entries = [TensorEntry.from_json(t, str(path)) for t in data.get("tensors", [])]
    frames = data.get("frames")
    if not isinstance(frames, list) or not all(isinstance(f, dict) and isinstance(f.get("index"), int) for f in frames):
        raise UserError(f"{path}: 'frames' must be a list of objects with an integer 'index'")
    info = {k: v for k, v in data.items() if k not in ("tensors", "frames")}
    return Dump(root, {e.name: e for e in entries}, {f["index"]: f for f in frames}, info)


def golden_dump(bundle: Path) -> Dump:
    """The golden frames of a bundle as a dump (names as the emulator's dumps use them)."""
    from ..export.manifest import read_manifest

    manifest = read_manifest(bundle)
    try:
        boundary = {b["role"]: b for b in manifest["boundary"]}
        frames = manifest["golden"]["frames"]
    except (KeyError, TypeError) as e:
        raise UserError(f"{bundle / BUNDLE_MANIFEST}: no golden frames to compare ({e})") from None
    names = {"npu_input": boundary["npu_input"]["tensor"], "npu_output": boundary["npu_output"]["tensor"]}
    tensors, dump_frames = {}, {}
    for frame in frames:
        files = {}
        for key, array in frame["arrays"].items():
            name = names.get(key, key)
            q = boundary.get(key)
            entry = TensorEntry(name, array["dtype"], list(array["shape"]), q["scale"] if q else None,
                                q["zero_point"] if q else None, "npu" if q else None)
            tensors.setdefault(name, entry)
            files[name] = {"file": array["file"], "dtype": array["dtype"], "shape": array["shape"]}
        dump_frames[int(frame["index"])] = {"index": int(frame["index"]), "files": files}
    order = ["color", "depth", "motion", names["npu_input"], names["npu_output"], "display"]
    ordered = {n: tensors[n] for n in order if n in tensors} | tensors
    return Dump(bundle, ordered, dump_frames, {"producer": "bundle golden frames"})
