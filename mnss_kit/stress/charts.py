"""Per-frame PSNR of every method, one PNG per scenario, with its cuts and events marked."""

from __future__ import annotations

import math
from pathlib import Path


def write_plots(doc: dict, out_dir: Path, suffix: str = ".png") -> dict[str, Path]:
    """``{scenario: PNG (or ``.svg``) path}`` under ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    out_dir.mkdir(parents=True, exist_ok=True)
    return {name: _plot(name, entry, out_dir / f"{name}{suffix}") for name, entry in doc["scenarios"].items()}


def _plot(name: str, entry: dict, path: Path) -> Path:
    import matplotlib.pyplot as plt

    from ..bench.charts import save_figure

    fig, ax = plt.subplots(figsize=(7.5, 3.5))
    for method, psnrs in entry["per_frame_psnr"].items():
        ax.plot(range(len(psnrs)), [p if p is not None and math.isfinite(p) else math.nan for p in psnrs],
                label=method, lw=1.2)
    labelled = set()
    for frame in entry["events"]:
        kind = "cut" if frame in entry["cuts"] else "pan end"
        ax.axvline(frame, color="grey" if kind == "cut" else "black", ls=":", lw=0.8,
                   label=None if kind in labelled else kind)
        labelled.add(kind)
    ax.set_xlabel("frame")
    ax.set_ylabel("PSNR (dB)")
    ax.set_title(f"{name}: {entry['case']}", fontsize=8)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)  # outside: no curve hidden
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return path
