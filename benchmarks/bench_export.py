"""Time ``mnss-kit export`` of a 1280x720 x2 bundle (default MNSS x2 config); JSON out.

Two settings, each repeated (medians):

``with_data``  calibration data given (``--data``, the tiny data config rendered once beforehand):
               the export itself: load, quantize + retarget to 720p, golden frames (rendered at
               640x360, 3 frames), write + check.
``default``    no ``--data``: the export also renders its calibration data (the quantize
               stage's default, mnss_kit/configs/data/tiny.yaml).

The model is the mnss_x2 config with random weights (timing does not depend on training).
The machine is shared; compare numbers from one run only.

    python benchmarks/bench_export.py --out benchmarks/results/export.json
"""

from __future__ import annotations

import argparse
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from mnss_kit.export.run import ExportRequest, export
from mnss_kit.fileio import atomic_write_json
from mnss_kit.model import checkpoint
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model
from mnss_kit.render.config import load_render_config
from mnss_kit.render.run import render_dataset

BUDGET_S = 60.0


def random_checkpoint(path: Path, config: str) -> Path:
    torch.manual_seed(0)
    model = build_model(load_model_config(config)).eval()
    with torch.no_grad():
        for name, p in model.named_parameters():
            if name.startswith(("recon", "aa")):
                p.add_(torch.randn_like(p) * 0.02)
    return checkpoint.save(path, model, {"jitter_pattern": "grid"})


def timed_exports(ckpt: Path, root: Path, data: Path | None, args) -> dict:
    totals, phases, size = [], [], 0
    for i in range(args.repeats):
        out = root / f"bundle_{i}"
        timings: dict[str, float] = {}
        start = time.perf_counter()
        manifest = export(ExportRequest(model=str(ckpt), out=out, resolution=args.resolution, device=args.device, data=data,
                                        progress=False), timings)
        totals.append(time.perf_counter() - start)
        phases.append(timings)
        size = sum(f["bytes"] for f in manifest["files"].values())
    return {
        "total_s": statistics.median(totals),
        "total_s_runs": totals,
        "phases_s": {k: statistics.median(p[k] for p in phases) for k in phases[0]},
        "bundle_bytes": size,
        "under_budget": statistics.median(totals) < BUDGET_S,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default="mnss_x2", help="model config (default mnss_x2)")
    parser.add_argument("--resolution", default="1280x720")
    parser.add_argument("--device", default="snapdragon_8_gen_1")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/export.json"))
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="bench-export-") as tmp:
        root = Path(tmp)
        ckpt = random_checkpoint(root / f"{args.config}.pt", args.config)
        start = time.perf_counter()
        render_dataset(load_render_config("tiny"), root / "data", progress=False)
        render_s = time.perf_counter() - start
        results = {
            "with_data": timed_exports(ckpt, root / "with_data", root / "data", args),
            "default": timed_exports(ckpt, root / "default", None, args),
        }
    report = {
        "benchmark": "export",
        "model_config": args.config,
        "resolution": args.resolution,
        "device": args.device,
        "repeats": args.repeats,
        "statistic": "median",
        "budget_s": BUDGET_S,
        "calibration_render_s": render_s,
        "results": results,
        "machine": {"python": platform.python_version(), "numpy": np.__version__, "torch": torch.__version__,
                    "processor": platform.processor(), "machine": platform.machine()},
    }
    atomic_write_json(args.out, report)
    for name, r in results.items():
        print(f"{name:10s} export {r['total_s']:.1f} s (median of {args.repeats}), phases "
              + ", ".join(f"{k} {v:.1f} s" for k, v in r["phases_s"].items()) + f", {r['bundle_bytes'] / 1e6:.1f} MB")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
