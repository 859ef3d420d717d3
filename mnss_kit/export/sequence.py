"""A recorded input sequence in a bundle (``mnss-kit export --sequence DIR --frames N``), for the
app to play in a loop through the bundle's GPU passes and NPU model.

Each ``input`` resource of the manifest gets one file ``sequence/NAME.zlib``: the N frames as
the texture holds them (dtype from its format, as the golden frames), shape ``(N, h, w,
channels)``, C order, little-endian, compressed as one zlib stream (RFC 1950, what
``java.util.zip.Inflater`` reads).  The manifest's ``sequence`` section lists the arrays (file,
dtype, shape, uncompressed bytes) and per frame the reset flag and the jitter the frame was
rendered with.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from ..errors import UserError
from .golden import dataset_frames, frame_entry, input_dtypes

SEQUENCE_DIR = "sequence"
COMPRESSION = "zlib"
ZLIB_LEVEL = 6


def sequence_frames(data: Path, lr_size, scale: int, inputs: list[str], n: int) -> tuple[list[dict], str]:
    """The first ``n`` frames of the first sequence in dataset ``data`` at the bundle's LR size."""
    if n < 1:
        raise UserError("--frames must be at least 1")
    if not data.is_dir():
        raise UserError(f"--sequence {data}: not a directory")
    found = dataset_frames(data, lr_size, scale, inputs, n)
    if found is None:
        raise UserError(f"--sequence {data}: no sequence of at least {n} frames at the bundle's LR size "
                        f"{lr_size[0]}x{lr_size[1]} (x{scale}); render or choose one at that size")
    return found


def write_sequence(root: Path, frames: list[dict], resources: list[dict], scale: int, jitter_table: list[dict], source: str) -> dict:
    """Write the sequence files under ``root``; returns the manifest's ``sequence`` section."""
    (root / SEQUENCE_DIR).mkdir()
    arrays = {}
    for name, dtype in input_dtypes(resources).items():
        stacked = np.stack([f[name] for f in frames]).astype(np.dtype(dtype).newbyteorder("<"))
        raw = np.ascontiguousarray(stacked).tobytes()
        file = f"{SEQUENCE_DIR}/{name}.zlib"
        (root / file).write_bytes(zlib.compress(raw, ZLIB_LEVEL))
        arrays[name] = {"file": file, "dtype": dtype, "shape": list(stacked.shape), "compression": COMPRESSION, "bytes": len(raw)}
    entries = [frame_entry(t, f["reset"] or t == 0, f["jitter"], scale, jitter_table) for t, f in enumerate(frames)]
    return {"source": source, "frame_count": len(frames), "frames": entries, "arrays": arrays}


def read_sequence_array(root: Path, entry: dict) -> np.ndarray:
    """An array of the ``sequence`` section, decompressed; ``UserError`` naming the file if it does not fit its entry."""
    name = entry["file"]
    try:
        raw = zlib.decompress((Path(root) / name).read_bytes())
    except (OSError, zlib.error) as e:
        raise UserError(f"{name}: cannot decompress ({e})") from None
    if len(raw) != entry["bytes"]:
        raise UserError(f"{name}: {len(raw)} bytes uncompressed, the manifest says {entry['bytes']}")
    dtype = np.dtype(entry["dtype"]).newbyteorder("<")
    if len(raw) != int(np.prod(entry["shape"])) * dtype.itemsize:
        raise UserError(f"{name}: {len(raw)} bytes do not hold shape {entry['shape']} of {entry['dtype']}")
    return np.frombuffer(raw, dtype).reshape(entry["shape"])
