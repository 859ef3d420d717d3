#!/usr/bin/env python
"""End-to-end check of the split pipeline against the unsplit PyTorch model.

    python scripts/studies/split_e2e.py --model mnss_x2 --calib data/train_x2 --data data/test_x2 \
        --bundle-out runs/split_e2e_bundle --resolution 640x360 --frames 60

Exports the model (int8 NPU stage calibrated on ``--calib``) unless ``--bundle`` names an
existing bundle, then runs two methods recurrently over the same frames of every held-out
sequence through ``mnss_kit.eval.loop.evaluate`` (so both are scored by the same metric code):

``pytorch_fp32``  the checkpoint's model in PyTorch float32, unsplit
``split``         the bundle in the emulator: GPU passes as the bundle's shader files on Mesa,
                  the NPU stage as ``npu.tflite`` in LiteRT (``--npu-profile`` picks the kernels)

The split output is the 8-bit display image the bundle shows.  Per sequence: PSNR, SSIM and
IF-SSIM of both against the HR reference, the PSNR difference, and the PSNR of the split
output against the PyTorch output.  Writes ``docs/studies/split_e2e.json`` and ``docs/studies/split_e2e.md``;
the budget verdict is computed from the measured means.
"""

from __future__ import annotations

import argparse
import logging
import math
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from mnss_kit.fileio import atomic_write_json, atomic_write_text, portable_command, portable_path  # noqa: E402
from mnss_kit.metrics.psnr import mse_psnr  # noqa: E402
from mnss_kit.ops.runtimes import DEFAULT_RUNTIME, runtime_names  # noqa: E402

BUDGET_DB = 0.2  # int8 loss budget of the quantization study (fp32 -> int8 mean PSNR)
DOC = REPO / "docs" / "studies" / "split_e2e.md"
JSON = REPO / "docs" / "studies" / "split_e2e.json"
METHODS = ("pytorch_fp32", "split")
log = logging.getLogger("split_e2e")


# The page's opening line: what the reader can do with it.
LEAD = "This page records how closely the split pipeline (shaders on Mesa, the int8 net in LiteRT) follows the unsplit PyTorch model."


def _hwc(tensor) -> np.ndarray:
    """``(1, C, h, w)`` torch -> ``(h, w, C)`` float32."""
    return np.ascontiguousarray(tensor[0].permute(1, 2, 0).numpy(), dtype=np.float32)


def split_method(emulator):
    """The emulator as an eval method: loader inputs -> ``(1, 3, H, W)`` display in [0, 1] (8-bit values).

    The state is only a start marker: the emulator carries its own history, and a ``None`` state
    (a new sequence) resets it.
    """
    import torch

    def run(inputs: dict, state):
        if state is None:
            emulator.reset()
        frame = {key: _hwc(inputs[key]) for key in ("color", "depth", "motion")}
        frame["jitter"] = inputs["jitter"].reshape(-1)[:2].numpy()
        frame["reset"] = bool(inputs["reset"].reshape(-1)[0] > 0.5)
        result = emulator.run_frame(frame)
        display = torch.from_numpy(result.display.astype(np.float32) / 255.0).permute(2, 0, 1)[None]
        return display, {}, True

    return run


class PairedOutputs:
    """Wraps the two methods so each frame's split output is compared with the PyTorch output of that frame.

    ``evaluate`` runs methods in dict order for every frame, so the PyTorch output is always the
    one of the current frame when the split method returns.  ``psnr_db`` holds one value per frame
    (``inf`` when identical).
    """

    def __init__(self, model_method, split):
        self.psnr_db: list[float] = []
        self.max_abs: list[float] = []
        self._last = None
        self._model, self._split = model_method, split

    def methods(self) -> dict:
        return {"pytorch_fp32": self._run_model, "split": self._run_split}

    def _run_model(self, inputs, state):
        output, aux, state = self._model(inputs, state)
        self._last = np.clip(output[0].detach().numpy().astype(np.float64), 0.0, 1.0)
        return output, aux, state

    def _run_split(self, inputs, state):
        output, aux, state = self._split(inputs, state)
        diff = output[0].numpy().astype(np.float64) - self._last
        mse = float(np.mean(diff * diff))
        self.psnr_db.append(mse_psnr(mse))
        self.max_abs.append(float(np.max(np.abs(diff))))
        return output, aux, state


def compare_sequence(model, emulator, seq_dir: Path, frames: int | None, progress: bool = False) -> dict:
    """Both methods over one sequence: per-method means, the PSNR difference and split-vs-PyTorch PSNR."""
    from mnss_kit.eval.methods import model_method
    from mnss_kit.eval.loop import evaluate

    paired = PairedOutputs(model_method(model), split_method(emulator))
    start = time.perf_counter()
    result = evaluate(paired.methods(), seq_dir, max_frames=frames, progress=progress)
    seconds = time.perf_counter() - start
    rows = result["per_frame"]
    means = {m: _means([r for r in rows if r["method"] == m]) for m in METHODS}
    finite = [p for p in paired.psnr_db if math.isfinite(p)]
    return {
        "frames": len(paired.psnr_db),
        "cuts": result["sequences"][seq_dir.name]["cuts"],
        "methods": means,
        "psnr_delta_db": means["pytorch_fp32"]["psnr"] - means["split"]["psnr"],
        "split_vs_pytorch_psnr_db": {
            "mean": statistics.fmean(finite) if finite else math.inf,
            "min": min(paired.psnr_db),
            "first_frame": paired.psnr_db[0],
            "last_frame": paired.psnr_db[-1],
        },
        "split_vs_pytorch_max_abs": max(paired.max_abs),
        "per_frame_split_vs_pytorch_psnr_db": paired.psnr_db,
        "per_frame_psnr_db": {m: [r["psnr"] for r in rows if r["method"] == m] for m in METHODS},
        "seconds": seconds,
    }


def _means(rows: list[dict]) -> dict:
    """Mean PSNR, SSIM and IF-SSIM (IF-SSIM over frames that have it: not the first frame or a cut)."""
    if_ssim = [r["if_ssim"] for r in rows if not math.isnan(r["if_ssim"])]
    return {
        "psnr": statistics.fmean(r["psnr"] for r in rows),
        "ssim": statistics.fmean(r["ssim"] for r in rows),
        "if_ssim": statistics.fmean(if_ssim) if if_ssim else None,
    }


def summarize(sequences: dict, budget_db: float) -> dict:
    """Means over sequences (each weighted by its frames) and the budget verdict."""
    frames = sum(s["frames"] for s in sequences.values())

    def weighted(get):
        return sum(get(s) * s["frames"] for s in sequences.values()) / frames

    overall = {m: {"psnr": weighted(lambda s: s["methods"][m]["psnr"]),
                   "ssim": weighted(lambda s: s["methods"][m]["ssim"])} for m in METHODS}
    delta = overall["pytorch_fp32"]["psnr"] - overall["split"]["psnr"]
    worst = max(s["psnr_delta_db"] for s in sequences.values())
    return {
        "frames": frames,
        "methods": overall,
        "psnr_delta_db": delta,
        "worst_sequence_psnr_delta_db": worst,
        "split_vs_pytorch_min_psnr_db": min(s["split_vs_pytorch_psnr_db"]["min"] for s in sequences.values()),
        "budget_db": budget_db,
        "budget_holds_overall": delta <= budget_db,
        "budget_holds_every_sequence": worst <= budget_db,
    }


def _f(value, digits: int) -> str:
    return "n/a" if value is None else ("inf" if value == math.inf else f"{value:.{digits}f}")


def write_doc(report: dict, path: Path = DOC) -> None:
    s = report["summary"]
    lines = [
        "# Split pipeline against the unsplit PyTorch model",
        "",
        LEAD,
        "",
        "Generated by `scripts/studies/split_e2e.py` (numbers from `docs/studies/split_e2e.json`).  Command:",
        "",
        f"    {report['command']}",
        "",
        f"`{report['model']}` exported at {report['resolution']} output, int8 NPU stage calibrated on "
        f"`{report['calibration']}`.  **split**: the bundle's GPU shader files on Mesa ({report['gpu_renderer']}), "
        f"`npu.tflite` in LiteRT {report['litert_version']} with the `{report['npu_profile']}` kernel set "
        f"({report['npu_kernels']}); its output is the 8-bit display image.  **pytorch_fp32**: the checkpoint "
        "in PyTorch float32, not split.  Both run recurrently from frame 0 of each sequence over the same "
        "frames, scored by `mnss_kit.metrics` through `mnss_kit.eval.loop.evaluate` (IF-SSIM excludes the "
        "first frame and cuts).",
        "",
        "| sequence | frames | cuts | PSNR fp32 | PSNR split | ΔPSNR (fp32 − split) | SSIM fp32 | SSIM split "
        "| IF-SSIM fp32 | IF-SSIM split | split vs fp32 PSNR (mean / min) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, q in report["sequences"].items():
        a, b = q["methods"]["pytorch_fp32"], q["methods"]["split"]
        v = q["split_vs_pytorch_psnr_db"]
        lines.append(f"| {name} | {q['frames']} | {', '.join(map(str, q['cuts'])) or '-'} | {a['psnr']:.3f} | {b['psnr']:.3f} "
                     f"| {q['psnr_delta_db']:+.3f} | {a['ssim']:.4f} | {b['ssim']:.4f} | {_f(a['if_ssim'], 4)} "
                     f"| {_f(b['if_ssim'], 4)} | {_f(v['mean'], 2)} / {_f(v['min'], 2)} |")
    a, b = s["methods"]["pytorch_fp32"], s["methods"]["split"]
    lines.append(f"| **all** | {s['frames']} | | {a['psnr']:.3f} | {b['psnr']:.3f} | {s['psnr_delta_db']:+.3f} "
                 f"| {a['ssim']:.4f} | {b['ssim']:.4f} | | | min {_f(s['split_vs_pytorch_min_psnr_db'], 2)} |")
    verdict = "holds" if s["budget_holds_overall"] else "does NOT hold"
    every = "holds" if s["budget_holds_every_sequence"] else "does not hold"
    lines += [
        "",
        f"Budget: mean PSNR loss of the split pipeline ≤ {s['budget_db']} dB against fp32.  Measured "
        f"{s['psnr_delta_db']:+.3f} dB over all {s['frames']} frames: the budget **{verdict}**; per sequence "
        f"(worst {s['worst_sequence_psnr_delta_db']:+.3f} dB) it {every}.",
        "",
        "ΔPSNR is the difference of mean PSNRs against the HR reference (positive: the split pipeline is "
        "worse).  \"split vs fp32 PSNR\" compares the two outputs directly, per frame.",
        "",
    ]
    atomic_write_text(path, "\n".join(lines))


def _environment(emulator) -> dict:
    from importlib.metadata import version

    from mnss_kit.emulate.npu import get_npu_profile

    renderer = "unknown"
    ctx = getattr(emulator.runner.passes, "ctx", None) or getattr(emulator.runner.passes, "context", None)
    if ctx is not None:
        renderer = f"{ctx.info.get('GL_RENDERER', '?')}, {ctx.info.get('GL_VERSION', '?')}"
    profile = get_npu_profile(emulator.npu_profile)
    return {"gpu_renderer": renderer, "litert_version": version("ai-edge-litert"),
            "npu_kernels": profile.description}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="mnss_x2", help="checkpoint path or shipped name")
    parser.add_argument("--calib", type=Path, required=True, help="calibration dataset")
    parser.add_argument("--data", type=Path, required=True, help="held-out dataset")
    parser.add_argument("--sequences", nargs="*", help="sequence names to run (default: all)")
    parser.add_argument("--resolution", default="640x360", help="output size WxH of the bundle")
    parser.add_argument("--bundle", type=Path, help="use this bundle instead of exporting one")
    parser.add_argument("--bundle-out", type=Path, help="where to export (required unless --bundle is given)")
    parser.add_argument("--frames", type=int, default=60, help="first N frames of each sequence")
    parser.add_argument("--npu-profile", default=DEFAULT_RUNTIME, choices=runtime_names("litert"))
    parser.add_argument("--budget-db", type=float, default=BUDGET_DB)
    parser.add_argument("--json", type=Path, default=JSON)
    parser.add_argument("--doc", type=Path, default=DOC)
    args = parser.parse_args(argv)
    if args.bundle is None and args.bundle_out is None:
        parser.error("give --bundle-out (where to export) or --bundle (an existing bundle)")
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")

    import torch

    from mnss_kit.dataset.format import find_sequences
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.model import checkpoint

    torch.set_num_threads(1)
    bundle = args.bundle
    if bundle is None:
        from mnss_kit.cli import main as cli

        bundle = args.bundle_out
        code = cli(["export", args.model, "--out", str(bundle), "--data", str(args.calib),
                    "--resolution", args.resolution, "--overwrite", "--no-progress"])
        if code != 0:
            return code
    model, _ = checkpoint.load(args.model)
    emulator = Emulator(bundle, args.npu_profile, "litert", "mesa")
    seq_dirs = [d for d in find_sequences(args.data) if not args.sequences or d.name in args.sequences]
    report = {
        "command": "python scripts/studies/split_e2e.py " + portable_command(argv if argv is not None else sys.argv[1:]),
        "model": args.model, "resolution": args.resolution, "calibration": portable_path(args.calib), "data": portable_path(args.data),
        "bundle": portable_path(bundle), "npu_profile": args.npu_profile, "npu_backend": "litert", "gpu_backend": "mesa",
        **_environment(emulator), "sequences": {},
    }
    for seq_dir in seq_dirs:
        q = compare_sequence(model, emulator, seq_dir, args.frames, progress=True)
        report["sequences"][seq_dir.name] = q
        log.info("%s: fp32 %.3f dB, split %.3f dB, delta %+.3f dB, split vs fp32 %.2f dB (%.0f s)", seq_dir.name,
                 q["methods"]["pytorch_fp32"]["psnr"], q["methods"]["split"]["psnr"], q["psnr_delta_db"],
                 q["split_vs_pytorch_psnr_db"]["mean"], q["seconds"])
        report["summary"] = summarize(report["sequences"], args.budget_db)
        atomic_write_json(args.json, report)  # after every sequence, so a long run keeps what it measured
        write_doc(report, args.doc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
