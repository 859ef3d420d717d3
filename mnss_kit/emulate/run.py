"""The emulate stage's entry, :func:`run_dataset` (``mnss-kit emulate``): dataset sequences through
the emulator: display frames, per-frame metrics and optional tensor dumps.

Output directory (one sub-directory per sequence)::

    OUT/metrics.json                 settings, per-frame metrics, summary per sequence
    OUT/<sequence>/frame_00000.png   the display output (8-bit)
    OUT/<sequence>/dump/             with ``dump``: every named tensor of every frame (``.dump``)

Per frame: seconds per stage, PSNR of the display against ``hr/reference`` when the sequence has
it, and the share of NPU output values at the int8 limits (saturation).
"""

from __future__ import annotations

import io
import logging
import math
import statistics
from pathlib import Path
from typing import Iterator

import numpy as np

from ..dataset.format import SequenceMeta, find_sequences, key_buffer, read_buffer, read_meta
from ..errors import UserError
from ..fileio import atomic_directory, atomic_write_bytes, atomic_write_json
from ..metrics.psnr import psnr
from .dump import DumpWriter
from .frame_loop import Emulator

log = logging.getLogger(__name__)


def sequence_frames(seq_dir: Path, meta: SequenceMeta, frames: int | None,
                    inputs: list[str]) -> Iterator[tuple[int, dict, np.ndarray | None]]:
    """``(index, frame, reference or None)`` for the first ``frames`` frames, with the bundle
    ``inputs``; the first one is a reset."""
    has_reference = "reference" in meta.buffers.get("hr", [])
    for name in inputs:
        res, buffer = key_buffer(name)
        if buffer not in meta.buffers.get(res, []):
            raise UserError(f"{seq_dir}: the bundle reads buffer {res}/{buffer}, which this sequence lacks (meta.json buffers.{res})")
    for i, fm in enumerate(meta.frames[:frames] if frames else meta.frames):
        frame = {key: read_buffer(seq_dir, meta, *key_buffer(key), fm.index) for key in inputs}
        frame["jitter"] = np.asarray(fm.jitter, np.float32)
        frame["reset"] = bool(fm.reset) or i == 0
        reference = read_buffer(seq_dir, meta, "hr", "reference", fm.index) if has_reference else None
        yield fm.index, frame, reference


def check_data(emulator: Emulator, seq_dir: Path, meta: SequenceMeta) -> None:
    """data check's checks (its errors refuse the sequence), then the bundle's sizes and jitter."""
    from ..dataset.check import require_clean

    require_clean(seq_dir)
    scale = emulator.spec.scale
    if meta.scale != scale:
        raise UserError(f"{seq_dir}: scale {meta.scale}, the bundle is x{scale}")
    if tuple(meta.lr_size) != tuple(emulator.spec.lr_size):
        raise UserError(f"{seq_dir}: lr_size {list(meta.lr_size)}, the bundle expects {list(emulator.spec.lr_size)}")
    table = ((emulator.spec.manifest or {}).get("jitter") or {}).get("sequence") or []
    offsets = {tuple(np.float32(e["offset"]).tolist()) for e in table}
    foreign = [f.index for f in meta.frames if offsets and tuple(np.float32(f.jitter).tolist()) not in offsets]
    if foreign:
        log.warning("%s: %d frame(s) (first: %d) have a jitter offset outside the bundle's '%s' sequence; "
                    "the model was trained for that pattern", seq_dir.name, len(foreign), foreign[0],
                    emulator.spec.manifest["jitter"].get("pattern"))


def _png(display: np.ndarray) -> bytes:
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(display, np.uint8)).save(buffer, format="PNG")
    return buffer.getvalue()


def run_sequence(emulator: Emulator, seq_dir: Path, out_dir: Path | None, dump: bool, frames: int | None,
                 progress: bool = False) -> list[dict]:
    """Emulate one sequence from its first frame; returns per-frame metrics, writes into ``out_dir``."""
    meta = read_meta(seq_dir)
    check_data(emulator, seq_dir, meta)
    emulator.reset()
    writer = None
    if dump and out_dir is not None:
        writer = DumpWriter(out_dir / "dump", {"producer": "mnss-kit emulate", "sequence": seq_dir.name,
                                               "npu_profile": emulator.npu_profile, "npu_backend": emulator.npu_backend,
                                               "gpu_backend": emulator.gpu_backend})
    rows = []
    total = min(frames or meta.frame_count, meta.frame_count)
    items = sequence_frames(seq_dir, meta, frames, emulator.runner.inputs)
    if progress:
        from tqdm import tqdm

        items = tqdm(items, total=total, desc=f"emulate {seq_dir.name}", unit="frame")
    for index, frame, reference in items:
        result = emulator.run_frame(frame, keep_all=writer is not None)
        npu_out = result.npu_output
        row = {
            "sequence": seq_dir.name,
            "frame": index,
            "reset": frame["reset"],
            "seconds": {k: round(v, 6) for k, v in result.seconds.items()},
            "npu_output_saturated": float(np.mean((npu_out == -128) | (npu_out == 127))),
        }
        if reference is not None:
            row["psnr_db"] = psnr(result.display.astype(np.float32) / 255.0, np.clip(reference, 0.0, 1.0))
        rows.append(row)
        if out_dir is not None:
            atomic_write_bytes(out_dir / f"frame_{index:05d}.png", _png(result.display))
        if writer is not None:
            writer.write_frame(index, result.tensors, result.entries)
    return rows


def summarize(rows: list[dict]) -> dict:
    """Median seconds per stage and mean PSNR (frames with a reference; identical frames excluded)."""
    out = {"frames": len(rows)}
    if rows:
        for key in rows[0]["seconds"]:
            out[f"median_seconds_{key}"] = statistics.median(r["seconds"][key] for r in rows)
    psnrs = [r["psnr_db"] for r in rows if math.isfinite(r.get("psnr_db", math.nan))]
    if psnrs:
        out["mean_psnr_db"] = statistics.fmean(psnrs)
    return out


def run_dataset(emulator: Emulator, data_dir: str | Path, out_dir: str | Path | None = None, dump: bool = False,
                frames: int | None = None, overwrite: bool = False, progress: bool = False) -> dict:
    """Every sequence under ``data_dir`` (a dataset or one sequence) from its first frame.

    Returns ``{"sequences": {name: {"frames": [per-frame metrics], "summary": ...}}, ...}``;
    with ``out_dir`` also writes display PNGs, ``metrics.json`` and (``dump``) tensor dumps
    (module docstring).
    """
    if out_dir is not None:
        return emulate_dataset(emulator, data_dir, out_dir, dump, frames, overwrite, progress)
    report = {"sequences": {}}
    for seq_dir in find_sequences(data_dir):
        rows = run_sequence(emulator, seq_dir, None, False, frames, progress)
        report["sequences"][seq_dir.name] = {"frames": rows, "summary": summarize(rows)}
    return report


def emulate_dataset(emulator: Emulator, data: str | Path, out: str | Path, dump: bool = False, frames: int | None = None,
                    overwrite: bool = False, progress: bool = False) -> dict:
    """Every sequence of ``data`` through ``emulator``; writes ``out`` (module docstring) and returns the metrics."""
    sequences = find_sequences(data)
    report = {"bundle": emulator.spec.source, "npu_profile": emulator.npu_profile, "npu_backend": emulator.npu_backend,
              "gpu_backend": emulator.gpu_backend, "sequences": {}}
    with atomic_directory(out, overwrite=overwrite) as staging:
        for seq_dir in sequences:
            rows = run_sequence(emulator, seq_dir, staging / seq_dir.name, dump, frames, progress)
            report["sequences"][seq_dir.name] = {"frames": rows, "summary": summarize(rows)}
        atomic_write_json(staging / "metrics.json", report)
    return report
