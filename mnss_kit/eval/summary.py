"""Per-frame rows -> per-method and per-sequence summaries, including recovery after cuts.

Averages are over frames (each frame weighs the same); frames where a metric
does not exist (IF-SSIM on a reset frame) are left out of that metric.
Errors inside disocclusion masks are weighted by pixel count across frames.
"""

from __future__ import annotations

import math
from statistics import median

import numpy as np

from ..metrics.psnr import mse_psnr

RECOVERY_TOLERANCE_DB = 0.5
METRICS = ("psnr", "ssim", "if_ssim", "temporal_error", "phase_offset", "flip")


def summarize(rows: list[dict], sequences: dict[str, dict], methods: list[str]) -> dict:
    """``{"frames", "methods", "sequences"}`` from the per-frame rows (see ``loop.evaluate``)."""
    out_sequences = {}
    for seq, info in sequences.items():
        seq_rows = [r for r in rows if r["sequence"] == seq]
        per_method = {}
        for m in methods:
            mrows = sorted((r for r in seq_rows if r["method"] == m), key=lambda r: r["frame"])
            stats = method_stats(mrows)
            stats.update(recovery(mrows))
            per_method[m] = stats
        out_sequences[seq] = dict(info, methods=per_method)
    out_methods = {}
    for m in methods:
        stats = method_stats([r for r in rows if r["method"] == m])
        cuts = [k for s in out_sequences.values() for k in s["methods"][m]["frames_to_recover"]]
        warmups = [s["methods"][m]["warmup_frames"] for s in out_sequences.values()]
        stats["frames_to_recover_after_cut"] = _mean_or_none(cuts)
        stats["cuts_not_recovered"] = sum(1 for k in cuts if k is None)
        stats["warmup_frames"] = _mean_or_none(warmups)
        out_methods[m] = stats
    frames = sum(info["frames"] for info in sequences.values())
    return {"frames": frames, "methods": out_methods, "sequences": out_sequences}


def method_stats(rows: list[dict]) -> dict:
    """Means of the per-frame metrics, plus pixel-weighted errors inside disocclusion masks."""
    stats = {"frames": len(rows)}
    for key in METRICS:
        values = [r[key] for r in rows if key in r and not math.isnan(r[key])]
        if key == "flip" and not values:  # only measured with --flip
            continue
        stats[key] = float(np.mean(values)) if values else None
    finite_psnr = [r["psnr"] for r in rows if math.isfinite(r["psnr"])]
    stats["psnr_median"] = float(median(finite_psnr)) if finite_psnr else None
    holes = [(r["disoccluded_pixels"], r["disocclusion_l1"], r["disocclusion_mse"]) for r in rows if r["disoccluded_pixels"] > 0]
    count = sum(h[0] for h in holes)
    stats["disoccluded_pixels"] = count
    if count:
        mse = sum(n * e for n, _, e in holes) / count
        stats["disocclusion_l1"] = sum(n * e for n, e, _ in holes) / count
        stats["disocclusion_psnr"] = mse_psnr(mse)
    else:
        stats["disocclusion_l1"] = stats["disocclusion_psnr"] = None
    return stats


def recovery(rows: list[dict], tolerance_db: float = RECOVERY_TOLERANCE_DB) -> dict:
    """Frames until PSNR is back within ``tolerance_db`` of the sequence's steady median.

    ``rows`` are one method's frames of one sequence, in order.  The steady
    median is taken over the second half of every stretch between resets
    (the first frame counts as a reset).  Returns ``warmup_frames`` (for the
    first frame) and ``frames_to_recover`` (one entry per camera cut; ``None``
    if PSNR never came back before the next reset or the end).
    """
    psnrs = [r["psnr"] for r in rows]
    if not psnrs:
        return {"warmup_frames": None, "frames_to_recover": []}
    frames = frames_to_recover(psnrs, [i for i, r in enumerate(rows) if r["reset"] and i > 0], tolerance_db)
    return {"warmup_frames": frames[0], "frames_to_recover": frames[1:]}


def frames_to_recover(psnrs: list[float], events: list[int], tolerance_db: float = RECOVERY_TOLERANCE_DB) -> list[int | None]:
    """Per stretch (frame 0, then each frame of ``events``): frames until PSNR is back within
    ``tolerance_db`` of the steady median, the median over the second half of every stretch.
    ``None`` where PSNR never came back before the next event or the end."""
    bounds = sorted({0, *events}) + [len(psnrs)]
    spans = list(zip(bounds, bounds[1:]))
    steady = [p for a, b in spans for p in psnrs[a + (b - a) // 2 : b]]
    target = median(steady) - tolerance_db
    return [next((i - a for i in range(a, b) if psnrs[i] >= target), None) for a, b in spans]


def _mean_or_none(values: list) -> float | None:
    present = [v for v in values if v is not None]
    return float(np.mean(present)) if present else None
