"""``mnss-kit demo``: the whole chain on a tiny built-in scene set, in a few minutes.

Renders a small training set and a held-out set, trains a tiny model of the default family
(``ntaau_lr_x2_tiny``: a small net at LR steering TAAU) for a fixed time, evaluates it and the shipped
default model against bicubic and TAAU on the held-out frames, quantizes the NPU stage to int8
(calibrated on the training set, compared with fp32 on the held-out set), exports a bundle whose
golden frames come from the held-out set, checks that the emulator reproduces them and replays
the held-out set in the emulator, then writes ``report.md``: each table says which data it
measures.  Every step is the same subcommand a user would run, so the demo doubles as a worked
example; a rerun with the same ``--out`` resumes (finished steps are skipped).
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

MODEL_CONFIG = "ntaau_lr_x2_tiny"  # the default family's smallest config
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

    if not 0 < args.minutes < float("inf"):  # nan and inf too: they failed in the train step, minutes later
        raise UserError(f"--minutes must be a positive number of minutes, got {args.minutes:g}")
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
    steps.run("quantize", quant_dir / "report.json", ["quantize", str(model), "--data", str(train_data), "--eval-data",
                                                      str(test_data), "--out", str(quant_dir), "--overwrite"], optional=True)
    steps.run("export bundle", bundle / "manifest.json", ["export", str(quant_dir if quant_dir.exists() else model),
                                                          "--data", str(test_data), "--out", str(bundle), "--overwrite"],
              optional=True)
    if (bundle / "manifest.json").exists():  # an installation without export has no bundle to emulate
        steps.call("emulator on golden frames", out / GOLDEN_CHECK, lambda: check_golden(bundle, out / GOLDEN_CHECK))
        if json.loads((out / GOLDEN_CHECK).read_text())["mismatch"] is None:
            steps.run("emulate bundle", emulated / "metrics.json", ["emulate", str(bundle), "--data", str(test_data),
                                                                    "--out", str(emulated)], optional=True)
        else:  # emulate would refuse the held-out set, which holds the golden sequence: the report says where it differs
            log.warning("emulate bundle: skipped, the emulator does not reproduce the bundle's golden frames")
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


GOLDEN_CHECK = "emulator_golden.json"


def check_golden(bundle: Path, path: Path) -> Path:
    """The bundle's golden inputs through the emulator (numpy NPU interpreter with the golden frames'
    numerics profile, numpy GPU passes); writes whether every stored array came out within the
    manifest's tolerances, and the first frame that did not."""
    from .emulate.frame_loop import Emulator
    from .export.golden import golden_mismatch
    from .export.reader import open_bundle
    from .fileio import atomic_write_json

    stored = open_bundle(bundle)
    golden = stored.manifest["golden"]
    emulator = Emulator(bundle, golden["profile"])
    mismatch = None
    for i in range(len(golden["frames"])):
        emulator.run_frame(stored.golden_inputs(i))
        want = {k: v for k, v in stored.golden(i).items() if k not in emulator.runner.inputs}
        differs = golden_mismatch(stored.manifest, i, {k: emulator.runner.values[k] for k in want}, want)
        if differs:
            mismatch = f"frame {i}: {differs}"
            break
    return atomic_write_json(path, {"frames": len(golden["frames"]), "profile": golden["profile"], "source": golden["source"],
                                    "compared": sorted(want), "mismatch": mismatch})


class Steps:
    """Runs subcommands (and calls) in order, skipping those whose output already exists (resume)."""

    def __init__(self, out: Path, progress: bool):
        self.out = out
        self.progress = progress
        self.timings: dict[str, float] = {}

    def call(self, title: str, done: Path, work) -> None:
        """A step that is a function call rather than a subcommand."""
        if done.exists():
            log.info("%s: already done (%s)", title, done)
            return
        log.info("%s", title)
        start = time.perf_counter()
        work()
        self.timings[title] = time.perf_counter() - start

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
    """report.md: held-out quality, the int8 comparison, the emulator's result and a quality-vs-cost
    chart; every table names the data it measures, and a step that did not run says so."""
    from .fileio import atomic_write_text

    rows = method_rows(out)
    lines = ["# mnss-kit demo report", "",
             f"`{MODEL_CONFIG}`, a tiny model of the default family (a small net at LR steering TAAU), trained for a few "
             f"minutes on a tiny rendered set (render config `{TRAIN_DATA}`), then quantized to int8, exported as a bundle and "
             f"emulated; beside it the shipped default model `{SHIPPED_MODEL}` (trained by the toolkit on its full "
             "training set), bicubic and TAAU.  The tiny model's numbers show that the chain works, not what a full "
             "training reaches.", ""]
    lines += quality_section(out, rows) + int8_section(out) + emulator_section(out)
    if rows:
        chart = quality_cost_chart(rows, out / "quality_vs_cost.png")
        lines += ["## Quality against cost", "", "Data: the held-out set, as in the first table.", "",
                  f"![quality vs cost]({chart.name})", ""]
    lines += ["Step timings (s): " + (", ".join(f"{k} {v:.0f}" for k, v in timings.items()) or "none (every step resumed)"), ""]
    return atomic_write_text(out / "report.md", "\n".join(lines))


def held_out_label(ev: dict) -> str:
    """Which frames an evaluation measured: its sequences and frame count."""
    names = ", ".join(ev.get("sequences") or {})
    return f"held-out set {TEST_DATA} ({names}; {ev.get('frames', '?')} frames, never trained on)"


def quality_section(out: Path, rows: list[tuple[str, dict, float | None]]) -> list[str]:
    lines = ["## Quality on held-out sequences", ""]
    if not rows:
        return lines + ["Not run: no `eval.json` (the evaluate step did not finish).", ""]
    ev = json.loads((out / "eval.json").read_text()) if (out / "eval.json").exists() else {}
    lines += [f"Data: {held_out_label(ev)}; every method on the same frames.", "",
              "| method | PSNR (dB) | SSIM | IF-SSIM | MACs / output pixel |", "|---|---|---|---|---|"]
    for name, m, macs in rows:
        lines.append(f"| {name} | {m['psnr']:.2f} | {m['ssim']:.4f} | {m['if_ssim']:.4f} | {macs if macs is not None else '-'} |")
    if not (out / "eval_shipped.json").exists():
        lines += ["", f"`{SHIPPED_MODEL}` not evaluated: this installation ships no such checkpoint."]
    return lines + [""]


def int8_section(out: Path) -> list[str]:
    lines = [f"## int8 NPU stage of {MODEL_CONFIG}", ""]
    path = out / "int8" / "report.json"
    q = json.loads(path.read_text()) if path.exists() else {}
    if "fp32" not in q or "int8" not in q:
        return lines + ["Not run: no fp32-vs-int8 comparison (`mnss-kit quantize` skipped or unavailable).", ""]
    info = q.get("evaluation", {})
    where = "held-out, never trained on" if info.get("held_out") else "the calibration data, not held out"
    lines += [f"Calibration: {q.get('samples', '?')} recorded stage inputs from the training set ({q.get('data', '?')}).  "
              f"Comparison data: {info.get('data', '?')} ({where}; {info.get('sequences', '?')} sequences, "
              f"{info.get('frames', '?')} frames), the GPU part in float32 for both rows, the int8 stage in "
              f"LiteRT {info.get('int8_runtime', '?')}.", "",
              "| precision | PSNR (dB) | SSIM | IF-SSIM |", "|---|---|---|---|"]
    for name in ("fp32", "int8"):
        m = q[name]
        lines.append(f"| {name} | {m['psnr']:.2f} | {m['ssim']:.4f} | {m['if_ssim']:.4f} |")
    return lines + [""]


def emulator_section(out: Path) -> list[str]:
    """Whether the emulator reproduced the bundle's golden frames, and its PSNR per held-out sequence
    beside the fp32 and int8 pipelines of the quantize report."""
    lines = ["## Bundle in the emulator", ""]
    golden_path, metrics_path = out / GOLDEN_CHECK, out / "emulate" / "metrics.json"
    if not golden_path.exists() and not metrics_path.exists():
        return lines + ["Not run: no bundle (`mnss-kit export` skipped or unavailable).", ""]
    if golden_path.exists():
        g = json.loads(golden_path.read_text())
        verdict = (f"reproduced all {g['frames']} within the manifest's tolerances" if g["mismatch"] is None
                   else f"did not reproduce them: {g['mismatch']}")
        lines += [f"Golden frames ({g['source']}; {', '.join(g['compared'])} compared, numerics {g['profile']}): "
                  f"the emulator {verdict}.", ""]
    if metrics_path.exists():
        lines += emulated_table(json.loads(metrics_path.read_text()), out / "int8" / "report.json")
    return lines


def emulated_table(metrics: dict, quant_report: Path) -> list[str]:
    """Mean PSNR against the reference per held-out sequence: fp32, int8 (LiteRT) and the emulated bundle."""
    q = json.loads(quant_report.read_text()) if quant_report.exists() else {}
    paired = {s["sequence"]: s for s in q.get("sequences", [])}
    same = all(paired.get(name, {}).get("frames", seq["summary"]["frames"]) == seq["summary"]["frames"]
               for name, seq in metrics["sequences"].items())
    frames = "the same frames" if same else "the quantize report's frames, which are not all the emulated ones"
    lines = [f"Data: held-out set {TEST_DATA}, from the first frame of each sequence.  The emulated bundle runs the "
             "int8 NPU graph and the GPU passes with device numerics and shows 8-bit display codes; fp32 and int8 are "
             f"the quantize report's pipelines on {frames}.", "",
             "| held-out sequence | frames | fp32 PSNR (dB) | int8 PSNR (dB) | emulated bundle PSNR (dB) |",
             "|---|---|---|---|---|"]
    for name, seq in metrics["sequences"].items():
        s, pair = seq["summary"], paired.get(name, {})
        cells = [(pair.get("fp32") or {}).get("psnr"), (pair.get("int8") or {}).get("psnr"), s.get("mean_psnr_db")]
        lines.append(f"| {name} | {s['frames']} | " + " | ".join("-" if v is None else f"{v:.2f}" for v in cells) + " |")
    return lines + [""]


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
    """PSNR against MACs per output pixel: each network a labelled point (labels placed clear of each
    other), each baseline a line named in the legend beside the plot."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .bench.charts import BASELINE_STYLES, place_labels, save_figure

    networks = [(name, m["psnr"], macs) for name, m, macs in rows if macs is not None]
    baselines = [(name, m["psnr"]) for name, m, macs in rows if macs is None]
    fig, ax = plt.subplots(figsize=(7, 3.6), dpi=100)
    for i, (_, psnr, macs) in enumerate(networks):
        ax.scatter([macs], [psnr], s=40, color=f"C{i}")
    for (name, psnr), style in zip(baselines, BASELINE_STYLES * 4):
        ax.axhline(psnr, color="grey", lw=0.9, ls=style, label=name)
    ax.set_xlabel("MACs per output pixel")
    ax.set_ylabel(f"PSNR (dB), held-out {TEST_DATA}")
    ax.set_xlim(0, max([macs for *_, macs in networks], default=1) * 1.4)
    ax.margins(y=0.2)
    ax.grid(alpha=0.3)
    if baselines:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    fig.tight_layout()
    points = [(macs, psnr) for _, psnr, macs in networks]
    place_labels(ax, [(name, xy, f"C{i}") for i, ((name, *_), xy) in enumerate(zip(networks, points))], points,
                 [psnr for _, psnr in baselines])
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return path
