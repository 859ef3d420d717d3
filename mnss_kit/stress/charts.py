"""Per-frame PSNR of every method, one PNG per scenario, with its cuts and events marked."""

from __future__ import annotations

import math
from pathlib import Path

from ..fileio import atomic_output_path


def write_plots(doc: dict, out_dir: Path) -> dict[str, Path]:
    """``{scenario: PNG path}`` under ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    out_dir.mkdir(parents=True, exist_ok=True)
    return {name: _plot(name, entry, out_dir / f"{name}.png") for name, entry in doc["scenarios"].items()}


def _plot(name: str, entry: dict, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.5))
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
    ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_output_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    plt.close(fig)
    return path
