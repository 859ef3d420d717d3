#!/usr/bin/env python
"""The shipped FuseSR checkpoints against the held-out sets, in fp32 and int8, against MNSS, on cost.

    nice -n 10 python scripts/fusesr_shipped.py              # evaluate, quantize, export, emulate; JSON and doc
    python scripts/fusesr_shipped.py --doc-only              # regenerate docs/fusesr_shipped.md from its JSON

For each shipped model (``mnss_kit/zoo/``): ``mnss-kit eval`` with bicubic and TAAU on its
held-out set, ``mnss-kit quantize`` (minmax, calibrated on its training set, int8 against fp32 on
the held-out set), ``mnss-kit split`` estimates per device profile, and for the FuseSR models a
bundle (``mnss-kit export``) run by the emulator under every NPU profile against the runtime it
reproduces (int8 values that differ).  ``fusesr_x2_hybrid`` is set beside ``mnss_x2`` on the
same frames.  Every stage is skipped when its output exists, so an interrupted run resumes.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "scripts"))

from mnss_kit.cli import main_or_exit as cli  # noqa: E402
from mnss_kit.fileio import atomic_write_json, atomic_write_text  # noqa: E402

DOC = REPO / "docs" / "fusesr_shipped.md"
RESULTS = REPO / "docs" / "fusesr_shipped.json"
WORK = REPO / "reports" / "fusesr_shipped"  # eval JSON, int8 reports, bundles (git-ignored)
INT8_TARGET_DB = 0.2
EXACTNESS_FRAMES = 4
METRICS = (("psnr", "PSNR dB", "{:.2f}"), ("ssim", "SSIM", "{:.4f}"), ("if_ssim", "IF-SSIM", "{:.4f}"))


@dataclass
class Entry:
    name: str  # shipped model name
    train: str  # data directory names under --data
    test: str
    bundle_size: str  # export --resolution (HR WxH)
    exactness: bool  # export and emulate under every NPU profile
    quantize: tuple[str, ...] = ()  # mnss-kit quantize options of the int8 columns and the bundle (beside plain minmax PTQ)


ENTRIES = [
    Entry("fusesr_x4_l", "train_x4", "test_x4", "640x360", True),
    # minmax PTQ alone loses 0.25 dB here; a short quantization-aware fine-tune of the NPU stage recovers it
    Entry("fusesr_x2_hybrid", "train_x2", "test_x2", "640x360", True, ("--qat", "200")),
    Entry("mnss_x2", "train_x2", "test_x2", "640x360", False),
]
COMPARISONS = [("fusesr_x2_hybrid", "mnss_x2")]


# The page's opening line: what the reader can do with it.
LEAD = "Use this page to compare the shipped FuseSR models with the MNSS model in fp32 and int8, and to see their cost and bundles."


def evaluate(e: Entry, data: Path, frames: int) -> dict:
    out = WORK / "eval" / f"{e.name}.json"
    if not out.exists():
        cli(["eval", e.name, "--data", str(data / e.test), "--json", str(out), "--methods", "model", "bicubic", "taau",
             "--max-frames", str(frames), "--no-progress"])
    methods = json.loads(out.read_text())["methods"]
    return {m: {k: methods[m][k] for k, _, _ in METRICS} for m in ("model", "bicubic", "taau")}


def int8(e: Entry, data: Path, frames: int, options: tuple[str, ...]) -> dict:
    out = int8_dir(e, options)
    if not (out / "report.json").exists():
        cli(["quantize", e.name, "--data", str(data / e.train), "--eval-data", str(data / e.test), "--pipeline-frames",
             str(frames), *options, "--out", str(out), "--overwrite", "--no-progress"])
    report = json.loads((out / "report.json").read_text())
    return {"options": " ".join(options), **{k: report[k] for k in ("fp32", "int8", "delta")}}


def int8_dir(e: Entry, options: tuple[str, ...]) -> Path:
    return WORK / "int8" / (e.name + "".join(options).replace("--", "-"))


def device_ms(e: Entry) -> dict:
    from mnss_kit.split.device import device_names

    out = {}
    for device in device_names():
        path = WORK / "split" / f"{e.name}-{device}.json"
        if not path.exists():
            cli(["split", e.name, "--device", device, "--resolution", e.bundle_size, "--json", str(path)])
        out[device] = json.loads(path.read_text())["estimated_frame_ms"]
    return out


def exactness(e: Entry, data: Path) -> dict:
    """int8 values differing between the emulator and each profile's runtime on the first test sequence."""
    from emulator_exactness import bundle_frames, compare

    from mnss_kit.dataset.format import find_sequences
    from mnss_kit.ops.runtimes import RUNTIMES

    bundle = WORK / "bundle" / e.name
    if not (bundle / "manifest.json").exists():  # from the model's quantize run: its int8 NPU stage is the bundle's
        cli(["export", str(int8_dir(e, e.quantize)), "--checkpoint", e.name, "--out", str(bundle), "--data", str(data / e.train),
             "--overwrite", "--no-progress"])
    path = WORK / "exactness" / f"{e.name}.json"
    if not path.exists():
        seq = find_sequences(data / e.test)[0]
        frames = bundle_frames(bundle, seq, EXACTNESS_FRAMES)
        atomic_write_json(path, {"sequence": seq.name, "profiles": {p: compare(bundle, frames, p) for p in RUNTIMES}})
    return json.loads(path.read_text())


def record_of(name: str) -> dict:
    from mnss_kit.model.checkpoint import read_record, resolve

    path = resolve(name)
    record, _ = read_record(path)
    training = record.get("training", {})
    return {"macs_per_pixel": record.get("macs_per_pixel"), "params": record.get("params"),
            "steps": training.get("steps"), "train_minutes": (training.get("wall_time_s") or 0) / 60,
            "file_bytes": path.stat().st_size}


def run(args) -> dict:
    rows = []
    for e in ENTRIES:
        row = {"name": e.name, "test": e.test, "train": e.train, **record_of(e.name), "eval": evaluate(e, args.data, args.frames),
               "int8": int8(e, args.data, args.frames, e.quantize), "device_ms": device_ms(e)}
        if e.quantize:
            row["int8_all"] = int8(e, args.data, args.frames, ())
        if e.exactness:
            row["exactness"] = exactness(e, args.data)
        rows.append(row)
    return {"command": "nice -n 10 python scripts/fusesr_shipped.py", "frames_per_sequence": args.frames, "models": rows}


def model_table(rows: list[dict]) -> list[str]:
    out = ["| model | test set | PSNR dB | SSIM | IF-SSIM | TAAU PSNR | bicubic PSNR | int8 PSNR | int8 - fp32 dB | MACs/px | params | file KB | steps | train min |",
           "|" + "---|" * 14]
    for r in rows:
        m, i = r["eval"], r["int8"]
        out.append(f"| `{r['name']}` | `{r['test']}` | {m['model']['psnr']:.2f} | {m['model']['ssim']:.4f} | {m['model']['if_ssim']:.4f} | "
                   f"{m['taau']['psnr']:.2f} | {m['bicubic']['psnr']:.2f} | {i['int8']['psnr']:.2f} | {i['delta']['psnr']:+.3f} | "
                   f"{round(r['macs_per_pixel'])} | {r['params']} | {r['file_bytes'] / 1024:.0f} | {r['steps']} | {r['train_minutes']:.0f} |")
    return out


def comparison_lines(rows: list[dict]) -> list[str]:
    by = {r["name"]: r for r in rows}
    out = []
    for a, b in COMPARISONS:
        ra, rb = by[a], by[b]
        deltas = "; ".join(f"{t} {('{:+.2f} dB' if k == 'psnr' else '{:+.4f}').format(ra['eval']['model'][k] - rb['eval']['model'][k])}"
                           for k, t, _ in METRICS)
        int8_delta = ra["int8"]["int8"]["psnr"] - rb["int8"]["int8"]["psnr"]
        cost = ra["macs_per_pixel"] / rb["macs_per_pixel"]
        devices = ", ".join(f"{d} {ra['device_ms'][d]:.2f} vs {rb['device_ms'][d]:.2f} ms" for d in ra["device_ms"])
        out += [f"- `{a}` - `{b}` on the same frames of `{ra['test']}`: {deltas}; in int8 {int8_delta:+.2f} dB PSNR.",
                f"- Cost: {round(ra['macs_per_pixel'])} against {round(rb['macs_per_pixel'])} MACs per output pixel "
                f"({cost:.2f}x); estimated frame time at {ENTRIES[0].bundle_size} (estimates from the device profiles, "
                f"not measurements): {devices}."]
    return out


def exactness_lines(rows: list[dict]) -> list[str]:
    out = []
    for r in rows:
        if "exactness" not in r:
            continue
        x = r["exactness"]
        parts = ", ".join(f"{p} ({v['runtime']}) {v['int8_values_differing']} of {v['int8_values_compared']}"
                          for p, v in x["profiles"].items())
        out.append(f"- `{r['name']}` (`{x['sequence']}`, {EXACTNESS_FRAMES} frames): int8 values differing, emulator "
                   f"against the runtime: {parts}.")
    return out


def render_doc(results: dict) -> str:
    rows = results["models"]
    int8_ok = all(-r["int8"]["delta"]["psnr"] <= INT8_TARGET_DB for r in rows)
    all_int8 = [f"`{r['name']}` with minmax post-training quantization alone loses {-r['int8_all']['delta']['psnr']:.3f} dB; "
                f"its int8 columns and its bundle use `mnss-kit quantize {r['int8']['options']}` (a short quantization-aware "
                f"fine-tune of the NPU stage after it), which loses {-r['int8']['delta']['psnr']:.3f} dB."
                for r in rows if "int8_all" in r]
    return "\n".join([
        "# Shipped FuseSR models",
        "",
        LEAD,
        "",
        f"Generated by `{results['command']}` from `docs/fusesr_shipped.json`; do not edit by hand "
        "(`python scripts/fusesr_shipped.py --doc-only` regenerates it).",
        "",
        "Each model is trained by the command in docs/training.md (section *Reproducing the shipped models*) "
        "on the training set named below and evaluated on a held-out set it never saw, first "
        f"{results['frames_per_sequence']} frames of each sequence, recurrent, as `mnss-kit eval`.  int8: "
        "`mnss-kit quantize` (minmax, calibrated on the training set), the NPU stage in LiteRT's "
        "reference kernels and every GPU stage in float32, on the same held-out frames.",
        "",
        *model_table(rows),
        "",
        f"int8 target (at most {INT8_TARGET_DB} dB PSNR lost against fp32): "
        + ("met by every model." if int8_ok else "NOT met by every model (the int8 - fp32 column).") + " " + " ".join(all_int8),
        "",
        "## The x2 hybrid against the default MNSS model",
        "",
        *comparison_lines(rows),
        "",
        "## Bundles",
        "",
        "`mnss-kit export` of each FuseSR model, run by `mnss-kit emulate`'s frame loop with its numpy "
        "NPU kernels and again with the runtime each profile reproduces (`scripts/emulator_exactness.py`):",
        "",
        *exactness_lines(rows),
        "",
    ])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO / "data", help="directory holding train_x2, test_x2, train_x4, test_x4")
    parser.add_argument("--frames", type=int, default=15, help="frames evaluated per test sequence")
    parser.add_argument("--doc-only", action="store_true", help="only regenerate the doc from its JSON")
    args = parser.parse_args(argv)
    results = json.loads(RESULTS.read_text()) if args.doc_only else run(args)
    if not args.doc_only:
        atomic_write_json(RESULTS, results)
    atomic_write_text(DOC, render_doc(results))
    print(f"wrote {RESULTS} and {DOC}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
