"""Writing evaluation results: per-frame CSV, summary JSON, and a table for the terminal."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from ..fileio import atomic_write_json, atomic_write_text

CSV_COLUMNS = ("sequence", "frame", "method", "reset", "psnr", "ssim", "if_ssim", "temporal_error",
               "disoccluded_pixels", "disocclusion_l1", "disocclusion_mse", "flip")
TABLE_COLUMNS = (
    ("psnr", "PSNR dB", "{:.2f}"),
    ("ssim", "SSIM", "{:.4f}"),
    ("if_ssim", "IF-SSIM", "{:.4f}"),
    ("temporal_error", "temp.err", "{:.4f}"),
    ("disocclusion_psnr", "disocc dB", "{:.2f}"),
    ("frames_to_recover_after_cut", "cut recov.", "{:.1f}"),
    ("flip", "FLIP", "{:.4f}"),
)


def write_json(path: str | Path, result: dict) -> Path:
    """The summary without the per-frame rows (those go to the CSV)."""
    summary = {k: v for k, v in result.items() if k != "per_frame"}
    return atomic_write_json(path, summary)


def write_csv(path: str | Path, rows: list[dict]) -> Path:
    """One row per frame and method; empty cells where a metric does not exist."""
    columns = [c for c in CSV_COLUMNS if c != "flip" or any("flip" in r for r in rows)]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _cell(row.get(k)) for k in columns})
    return atomic_write_text(path, buf.getvalue())


def format_table(result: dict) -> str:
    """Methods as rows, summary metrics as columns."""
    methods = result["methods"]
    cols = [c for c in TABLE_COLUMNS if any(m.get(c[0]) is not None for m in methods.values())]
    header = ["method"] + [c[1] for c in cols]
    lines = [header]
    for name, stats in methods.items():
        cells = [name]
        for key, _, spec in cols:
            v = stats.get(key)
            cells.append("-" if v is None or (isinstance(v, float) and math.isnan(v)) else spec.format(v))
        lines.append(cells)
    widths = [max(len(line[i]) for line in lines) for i in range(len(header))]
    text = [" ".join(cell.ljust(widths[i]) if i == 0 else cell.rjust(widths[i]) for i, cell in enumerate(line)) for line in lines]
    frames = result.get("frames")
    reference = result.get("settings", {}).get("reference", "box")
    against = "" if reference == "box" else f", against the {reference} reference"
    text.append(f"({frames} frames in {len(result.get('sequences', {}))} sequence(s){against})")
    return "\n".join(text)


def _cell(value):
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value) if math.isinf(value) else f"{value:.6g}"
    return value
