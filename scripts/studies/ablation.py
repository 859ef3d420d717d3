#!/usr/bin/env python
"""MNSS ablations on the toolkit's own data: what the history reuses, and the jitter pattern.

    python scripts/studies/ablation.py --train-data data/train_x2 --test-data data/test_x2   # run (or resume), write the doc
    python scripts/studies/ablation.py --doc-only     # regenerate docs/studies/ablation.md from docs/studies/ablation.json

History: three models identical except ``model.history`` (output = reuse I_SS, lr_frame = reuse
the previous LR frame, none = single frame), trained on the train set for the same number of
steps with the same seed, evaluated on the held-out test set.  Jitter: small train and test
sets rendered twice with identical scenes, seeds and cameras, once with the grid pattern and
once with centre sampling; the same config is trained on each and evaluated on its own test
set.  Every stage goes through ``mnss_kit.cli.main`` (the code behind ``mnss-kit render``,
``train`` and ``eval``) and is skipped when its output exists, so an interrupted study resumes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from mnss_kit.cli import main_or_exit as cli  # noqa: E402
from mnss_kit.fileio import atomic_output_path, atomic_write_json, atomic_write_text, portable_path  # noqa: E402

DOC = REPO / "docs" / "studies" / "ablation.md"
RESULTS = REPO / "docs" / "studies" / "ablation.json"
WORK = REPO / "reports" / "ablation"  # rendered data, runs and eval JSON (git-ignored)
CONFIG = "mnss_x2"
# Optimizer updates per run: the same for every run of a study.  The first epoch (a quarter of
# the run) feeds the ground-truth history (gt_history_epochs: 1 in the config).
STEPS = {"history": 120, "jitter": 60}
EPOCHS = 4
THREADS = 2
EVAL_METHODS = ("model", "bicubic")
METRICS = (("psnr", "PSNR dB", "{:.2f}"), ("ssim", "SSIM", "{:.4f}"), ("if_ssim", "IF-SSIM", "{:.4f}"))
HISTORY_ORDER = ("output", "lr_frame", "none")  # the paper's ordering, best first
HISTORY_LABELS = {"output": "reuse I_SS (output)", "lr_frame": "reuse previous LR frame", "none": "single frame"}
JITTER_ORDER = ("grid", "center")
JITTER_LABELS = {"grid": "grid jitter", "center": "centre sampling"}


@dataclass
class Run:
    """One trained and evaluated model of the study."""

    name: str
    study: str  # "history" or "jitter"
    variant: str  # the history mode or the jitter pattern
    train_data: Path
    test_data: Path
    overrides: list[str] = field(default_factory=list)


# The page's opening line: what the reader can do with it.
LEAD = "This page records which parts of the MNSS design matter on the toolkit's data: what the history reuses, and the jitter pattern."


def plan(train_x2: Path, test_x2: Path, eval_frames: int) -> tuple[list[Run], list[tuple[str, str, Path]]]:
    """The runs and the renders ``(data config, pattern, out dir)`` they need."""
    runs = [Run(f"history_{mode}", "history", mode, train_x2, test_x2, [f"model.history={mode}"])
            for mode in HISTORY_ORDER]
    renders = []
    for pattern in JITTER_ORDER:
        train_dir, test_dir = WORK / "data" / f"train_{pattern}", WORK / "data" / f"test_{pattern}"
        renders += [("ablation_train", pattern, train_dir),
                    ("ablation_test", pattern, test_dir)]
        runs.append(Run(f"jitter_{pattern}", "jitter", pattern, train_dir, test_dir))
    return runs, renders


def render(config: str, pattern: str, out: Path) -> None:
    """Render (resumable: the renderer skips frames already on disk)."""
    cli(["render", config, "--out", str(out), "--set", f"jitter={pattern}", "--no-progress"])


def train(run: Run) -> Path:
    model = WORK / "runs" / run.name / "model.pt"
    if model.exists():
        return model
    train_keys = [f"train.train_data={run.train_data}", "train.val_data=null", f"train.total_steps={STEPS[run.study]}",
                  f"train.steps_per_epoch={STEPS[run.study] // EPOCHS}", "train.time_budget_min=null", f"train.threads={THREADS}",
                  "train.val_every=0", "train.checkpoint_every=30", "train.seed=0"]
    sets = [arg for key in run.overrides + train_keys for arg in ("--set", key)]
    cli(["train", CONFIG, "--out", str(model.parent), "--no-progress", *sets])
    return model


def evaluate(run: Run, model: Path, eval_frames: int) -> Path:
    out = WORK / "eval" / f"{run.name}.json"
    if not out.exists():
        cli(["eval", str(model), "--data", str(run.test_data), "--json", str(out), "--methods", *EVAL_METHODS,
             "--max-frames", str(eval_frames), "--no-progress"])
    return out


def collect(run: Run, model: Path, eval_json: Path) -> dict:
    from mnss_kit.model.checkpoint import read_record

    record, _ = read_record(model)
    training = record["training"]
    summary = json.loads(eval_json.read_text())
    methods = summary["methods"]
    return {
        "name": run.name, "study": run.study, "variant": run.variant,
        "train_data": portable_path(run.train_data), "test_data": portable_path(run.test_data), "overrides": run.overrides,
        "steps": training["steps"], "train_seconds": training["wall_time_s"], "final_loss": training["final_loss"],
        "eval_frames": summary.get("frames"),
        "model": {k: methods["model"][k] for k, _, _ in METRICS},
        "bicubic": {k: methods["bicubic"][k] for k, _, _ in METRICS},
    }


def run_study(args) -> dict:
    import torch

    torch.set_num_threads(THREADS)
    runs, renders = plan(args.train_data, args.test_data, args.eval_frames)
    start = time.monotonic()
    results = []
    if args.existing_only:  # collect the finished runs, run nothing
        for run in runs:
            model, eval_json = WORK / "runs" / run.name / "model.pt", WORK / "eval" / f"{run.name}.json"
            if model.exists() and eval_json.exists():
                results.append(collect(run, model, eval_json))
    else:
        for config, pattern, out in renders:
            render(config, pattern, out)
        for run in runs:
            model = train(run)
            results.append(collect(run, model, evaluate(run, model, args.eval_frames)))
    return {
        "command": "python scripts/studies/ablation.py" + (f" --eval-frames {args.eval_frames}" if args.eval_frames != 16 else ""),
        "config": CONFIG, "steps": STEPS, "epochs": EPOCHS, "threads": THREADS,
        "eval_frames_per_sequence": args.eval_frames, "wall_seconds_this_invocation": time.monotonic() - start,
        "runs": results,
    }


def current_names(results: dict) -> dict:
    """``results`` with the jitter runs' patterns by today's names: a file written before the grid
    pattern was renamed calls it mnss (``ops.jitter.RENAMED_PATTERNS``)."""
    from mnss_kit.ops.jitter import pattern_name

    runs = [dict(r, variant=pattern_name(r["variant"])) if r["study"] == "jitter" else r for r in results["runs"]]
    return {**results, "runs": runs}


def orderings(results: dict) -> list[dict]:
    """The paper's orderings checked on the measured numbers (one entry per adjacent pair)."""
    by = {(r["study"], r["variant"]): r for r in results["runs"]}
    checks = []
    for study, order, labels in (("history", HISTORY_ORDER, HISTORY_LABELS), ("jitter", JITTER_ORDER, JITTER_LABELS)):
        for better, worse in zip(order, order[1:]):
            claim = f"{labels[better]} > {labels[worse]}"
            if (study, better) not in by or (study, worse) not in by:
                checks.append({"study": study, "claim": claim, "measured": False})
                continue
            a, b = by[(study, better)]["model"], by[(study, worse)]["model"]
            checks.append({"study": study, "claim": claim, "measured": True,
                           **{k: {"delta": a[k] - b[k], "holds": a[k] > b[k]} for k, _, _ in METRICS}})
    return checks


def write_doc(results: dict) -> None:
    checks = orderings(results)
    chart = DOC.with_suffix(".png")
    write_chart(chart, results)
    atomic_write_text(DOC, render_doc(results, checks, chart.name))


def table(runs: list[dict], labels: dict) -> list[str]:
    head = "| variant | " + " | ".join(t for _, t, _ in METRICS) + " | bicubic PSNR dB | steps | train min |"
    out = [head, "|" + "---|" * (len(METRICS) + 4)]
    for r in runs:
        cells = [f.format(r["model"][k]) for k, _, f in METRICS]
        out.append(f"| {labels[r['variant']]} | " + " | ".join(cells)
                   + f" | {r['bicubic']['psnr']:.2f} | {r['steps']} | {r['train_seconds'] / 60:.1f} |")
    return out


def verdict(check: dict) -> str:
    if not check["measured"]:
        return "- " + check["claim"] + ": not measured (a run of this pair is missing)"
    def part(key, title, fmt):
        c = check[key]
        return f"{title} {'holds' if c['holds'] else 'does NOT hold'} ({fmt.format(c['delta'])})"
    return "- " + check["claim"] + ": " + "; ".join(part(k, t, "{:+.2f} dB" if k == "psnr" else "{:+.4f}")
                                                   for k, t, _ in METRICS)


def render_doc(results: dict, checks: list[dict], chart_name: str) -> str:
    runs = results["runs"]
    history = sorted((r for r in runs if r["study"] == "history"), key=lambda r: HISTORY_ORDER.index(r["variant"]))
    jitter = sorted((r for r in runs if r["study"] == "jitter"), key=lambda r: JITTER_ORDER.index(r["variant"]))
    measured = [c for c in checks if c["measured"]]
    psnr_all = len(measured) == len(checks) and all(c["psnr"]["holds"] for c in checks)
    out = [
        "# MNSS ablations on the toolkit's data",
        "",
        LEAD,
        "",
        f"Generated by `{results['command']}` from `docs/studies/ablation.json`; do not edit by hand "
        "(`python scripts/studies/ablation.py --doc-only` regenerates it from the JSON).",
        "",
        f"**Budget caveat.** Every model is `{results['config']}` trained for only "
        f"{results['steps']['history']} steps (history study) or {results['steps']['jitter']} steps (jitter "
        f"study) in {results['epochs']} epochs, the first with ground-truth history; within a study every run "
        "has the same seed and the same number of updates.  Runs were made on a 2-core CPU shared with other "
        "work, so the training minutes reflect the machine's load more than the model's cost. "
        "The orderings below are the orderings at this budget, not at convergence; differences of a few "
        "hundredths of a dB are within what another seed could change.",
        "",
        "## History: what the recurrent state reuses",
        "",
        f"Trained on `{history[0]['train_data']}`, evaluated on the held-out `{history[0]['test_data']}` "
        f"(first {results['eval_frames_per_sequence']} frames of each sequence). Only `model.history` differs.",
        "",
        *table(history, HISTORY_LABELS),
        "",
        "## Jitter: grid pattern (MNSS's order) against centre sampling",
        "",
        "Train and test sets (`mnss_kit/configs/data/ablation_train.yaml`, `ablation_test.yaml`, 160x90 -> 320x180) "
        "rendered twice with identical scenes, seeds and cameras, once per pattern; the same config is "
        "trained on each and evaluated on its own test set (the HR references are the same). With centre "
        "sampling at x2 the LR sample sits on the corner between the four sub-pixels of its tile; "
        "`mnss_kit.ops.jitter.subpixel_index` assigns it to the lower-right sub-pixel (1, 1), so the same "
        "HR position receives the sample every frame and the other three are never sampled.",
        "",
        *table(jitter, JITTER_LABELS),
        "",
        f"![model PSNR per variant]({chart_name})",
        "",
        "## Do the paper's orderings hold here?",
        "",
        "Computed from the tables (delta = first minus second):",
        "",
        *[verdict(c) for c in checks],
        "",
        ("All PSNR orderings of the paper hold on our data at this budget." if psnr_all else
         "Not every PSNR ordering of the paper is confirmed on our data at this budget; see the lines "
         "marked 'does NOT hold' or 'not measured' above."),
        "",
        *below_bicubic(runs),
    ]
    return "\n".join(out)


def below_bicubic(runs: list[dict]) -> list[str]:
    """A plain warning for every model that has not yet caught up with bicubic on PSNR."""
    names = [f"{r['name']} ({r['model']['psnr']:.2f} vs {r['bicubic']['psnr']:.2f} dB)"
             for r in runs if r["model"]["psnr"] <= r["bicubic"]["psnr"]]
    if not names:
        return []
    return [f"Undertrained at this budget: {', '.join(names)} are still below bicubic on PSNR, so those "
            "orderings compare two models that do not yet beat the baseline.", ""]


def write_chart(path: Path, results: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), dpi=90)
    for ax, (study, order, labels) in zip(axes, (("history", HISTORY_ORDER, HISTORY_LABELS),
                                                 ("jitter", JITTER_ORDER, JITTER_LABELS))):
        runs = {r["variant"]: r for r in results["runs"] if r["study"] == study}
        order = [v for v in order if v in runs]
        if not order:
            ax.set_axis_off()
            continue
        values = [runs[v]["model"]["psnr"] for v in order]
        bars = ax.bar([labels[v].replace(" (output)", "") for v in order], values, color="#66c2a5")
        ax.bar_label(bars, fmt="%.2f", fontsize=8)
        ax.set_ylim(min(values) - 1.0, max(values) + 0.5)
        ax.set_title(f"{study} ablation", fontsize=10)
        ax.set_ylabel("model PSNR dB")
        ax.tick_params(axis="x", labelsize=7)
    fig.tight_layout()
    with atomic_output_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train-data", type=Path,
                        help="training sequences of the history ablation (required unless --doc-only)")
    parser.add_argument("--test-data", type=Path,
                        help="held-out sequences of the history ablation (required unless --doc-only)")
    parser.add_argument("--eval-frames", type=int, default=16, help="frames evaluated per test sequence")
    parser.add_argument("--existing-only", action="store_true",
                        help="collect the runs already trained and evaluated, run nothing, write JSON and doc")
    parser.add_argument("--doc-only", action="store_true", help="only regenerate the doc from docs/studies/ablation.json")
    args = parser.parse_args(argv)
    if not args.doc_only and (args.train_data is None or args.test_data is None):
        parser.error("give --train-data and --test-data (or --doc-only)")
    if args.doc_only:
        results = current_names(json.loads(RESULTS.read_text()))
    else:
        results = run_study(args)
        atomic_write_json(RESULTS, results)
    write_doc(results)
    print(f"wrote {RESULTS}, {DOC} and {DOC.with_suffix('.png')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
