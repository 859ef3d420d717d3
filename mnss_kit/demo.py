"""``mnss-kit demo``: the whole chain on a tiny built-in scene set, in a few minutes.

Renders a small training set and a held-out set, trains the tiny MNSS x2
config for a fixed time, evaluates it and the shipped default model against
bicubic and TAAU on the held-out frames, quantizes the
NPU stage to int8, exports a bundle and replays it in the emulator, then writes
``report.md`` with a quality-versus-cost chart.  Every step is the same
subcommand a user would run, so the demo doubles as a worked example; a rerun
with the same ``--out`` resumes (finished steps are skipped).
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

from .zoo import DEFAULT_MODEL

HELP = "run the whole pipeline on a tiny built-in scene set (render, train, eval, quantize, export, emulate) and write a report"

log = logging.getLogger(__name__)

MODEL_CONFIG = "mnss_x2_tiny"
SHIPPED_MODEL = DEFAULT_MODEL  # the default model, trained by the toolkit on the full training set
TRAIN_DATA = "tiny"
TEST_DATA = "tiny_test"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", default="runs/demo", help="working directory (default: runs/demo)")
    parser.add_argument("--minutes", type=float, default=2.0, help="training time budget in minutes (default: 2)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    from .errors import UserError

    from .fileio import check_output

    if args.minutes <= 0:
        raise UserError("--minutes must be positive")
    out = check_output(args.out, "into")
    out.mkdir(parents=True, exist_ok=True)
    steps = Steps(out, progress=not args.no_progress)
    train_data, test_data = out / "data" / "train", out / "data" / "test"
    run_dir, model = out / "train", out / "train" / "model.pt"
    quant_dir, bundle, emulated = out / "int8", out / "bundle", out / "emulate"

    steps.run("render training set", train_data / ".done", ["render", TRAIN_DATA, "--out", str(train_data)])
    steps.run("render held-out set", test_data / ".done", ["render", TEST_DATA, "--out", str(test_data)])
    steps.run("train", model, ["train", MODEL_CONFIG, "--out", str(run_dir),
                               "--set", f"train.train_data={train_data}", "--set", "train.val_data=null",
                               "--set", f"train.time_budget_min={args.minutes}", "--set", "train.total_steps=100000",
                               "--set", "train.gt_history_epochs=0"] + (["--resume"] if (run_dir / "last.pt").exists() else []))
    steps.run("evaluate", out / "eval.json", ["eval", str(model), "--data", str(test_data), "--json", str(out / "eval.json"),
                                              "--crops", str(out / "crops"), "--methods", "model", "bicubic", "taau"])
    evaluate_shipped(steps, test_data, out / "eval_shipped.json")
    steps.run("quantize", quant_dir / "report.json", ["quantize", str(model), "--data", str(train_data), "--out", str(quant_dir),
                                                      "--overwrite"], optional=True)
    steps.run("export bundle", bundle / "manifest.json", ["export", str(quant_dir if quant_dir.exists() else model),
                                                          "--out", str(bundle), "--overwrite"], optional=True)
    steps.run("emulate bundle", emulated / "metrics.json", ["emulate", str(bundle), "--data", str(test_data),
                                                            "--out", str(emulated), "--frames", "6"], optional=True)
    report = write_report(out, steps.timings)
    print(f"demo finished in {sum(steps.timings.values()):.0f} s; report: {report}")
    return 0


def evaluate_shipped(steps: "Steps", test_data: Path, json_path: Path) -> None:
    """The shipped default model on the same held-out frames (its network only: the baselines are
    already in the tiny model's evaluation)."""
    from .model.checkpoint import shipped_names

    if SHIPPED_MODEL not in shipped_names():
        log.warning("evaluate shipped model: skipped, this installation ships no '%s' checkpoint", SHIPPED_MODEL)
        return
    steps.run("evaluate shipped model", json_path, ["eval", SHIPPED_MODEL, "--data", str(test_data),
                                                     "--json", str(json_path), "--methods", "model"])


class Steps:
    """Runs subcommands in order, skipping those whose output already exists (resume)."""

    def __init__(self, out: Path, progress: bool):
        self.out = out
        self.progress = progress
        self.timings: dict[str, float] = {}

    def run(self, title: str, done: Path, argv: list[str], optional: bool = False) -> None:
        from .cli import available_commands, main
        from .errors import UserError

        if done.exists():
            log.info("%s: already done (%s)", title, done)
            return
        if argv[0] not in available_commands():
            if optional:
                log.warning("%s: skipped, this installation has no '%s' command", title, argv[0])
                return
            raise UserError(f"demo needs the '{argv[0]}' command, which this installation lacks")
        log.info("%s: mnss-kit %s", title, " ".join(argv))
        start = time.perf_counter()
        code = main(argv + ([] if self.progress else ["--no-progress"]))
        self.timings[title] = time.perf_counter() - start
        if code != 0:
            raise UserError(f"demo step '{title}' failed (exit {code}); rerun with the same --out to resume")
        if done.name == ".done":
            done.write_text("")


def write_report(out: Path, timings: dict[str, float]) -> Path:
    """report.md with the evaluation table, the int8 comparison and a quality-vs-cost chart."""
    from .fileio import atomic_write_text

    rows = method_rows(out)
    lines = ["# mnss-kit demo report", "",
             f"{MODEL_CONFIG} trained for a few minutes on a tiny rendered set, beside the shipped default "
             f"model {SHIPPED_MODEL} (trained by the toolkit on its full training set), bicubic and TAAU, all on "
             "the same held-out sequences.  The tiny model's numbers show that the chain works, not what a "
             "full training reaches.", "",
             "| method | PSNR (dB) | SSIM | IF-SSIM | MACs / output pixel |", "|---|---|---|---|---|"]
    for name, m, macs in rows:
        lines.append(f"| {name} | {m['psnr']:.2f} | {m['ssim']:.4f} | {m['if_ssim']:.4f} | {macs if macs is not None else '-'} |")
    quant = out / "int8" / "report.json"
    if quant.exists():
        q = json.loads(quant.read_text())
        if "fp32" in q and "int8" in q:
            lines += ["", f"| NPU stage of {MODEL_CONFIG} | PSNR (dB) | SSIM | IF-SSIM |", "|---|---|---|---|"]
            for name in ("fp32", "int8"):
                m = q[name]
                lines.append(f"| {name} | {m['psnr']:.2f} | {m['ssim']:.4f} | {m['if_ssim']:.4f} |")
    chart = quality_cost_chart(rows, out / "quality_vs_cost.png")
    lines += ["", f"![quality vs cost]({chart.name})", "", "Step timings (s): " +
              ", ".join(f"{k} {v:.0f}" for k, v in timings.items()), ""]
    return atomic_write_text(out / "report.md", "\n".join(lines))


def method_rows(out: Path) -> list[tuple[str, dict, float | None]]:
    """``(label, metrics, MACs per output pixel or None)`` for every method evaluated on the held-out
    set: the demo's model (``eval.json``), then the shipped model (``eval_shipped.json``, when run)."""
    rows = []
    for path, label in ((out / "eval.json", f"{MODEL_CONFIG}, trained here"),
                        (out / "eval_shipped.json", f"{SHIPPED_MODEL}, shipped")):
        if not path.exists():
            continue
        ev = json.loads(path.read_text())
        macs = (ev.get("model") or {}).get("macs_per_pixel")
        for name, m in ev["methods"].items():
            network = name.startswith("model")
            rows.append((f"{name} ({label})" if network else name, m, macs if network else None))
    return rows


def quality_cost_chart(rows: list[tuple[str, dict, float | None]], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.6), dpi=100)
    for name, m, macs in rows:
        ax.scatter([macs or 0], [m["psnr"]], label=name)
    ax.set_xlabel("MACs per output pixel (0 = no network)")
    ax.set_ylabel("PSNR (dB), held-out")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
