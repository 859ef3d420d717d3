#!/usr/bin/env python
"""Fine-tune the shipped model on a studio's own frames: the worked example of docs/training.md.

    nice -n 10 python scripts/finetune_example.py [--work runs/finetune_example] [--minutes 10]
    python scripts/finetune_example.py --doc-only    # rewrite the doc section from the JSON

The studio's game is stood in for by the built-in factory scene (``studio_x2``), a scene family
the shipped ``mnss_x2`` never saw.  Steps, through the toolkit's own commands; each is skipped
when its output exists (every output is written atomically, so one that exists is complete):

1. render   ``mnss-kit render studio_x2`` (resumes frame by frame)   -> WORK/render
2. capture  the renders written as one Arm NSS capture                -> WORK/capture
3. import   ``mnss-kit data import nss``                              -> WORK/imported
4. split    the last ``--held-out`` sequences are held out (WORK/heldout links to them)
5. train    ``mnss-kit train mnss_x2 --init mnss_x2`` for ``--minutes`` on the others -> WORK/run
6. eval     ``mnss-kit eval`` on WORK/heldout: the fine-tuned model, bicubic, TAAU, the shipped mnss_x2
7. report   benchmarks/results/finetune_example.json, then the generated block of docs/training.md
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from doc_blocks import replace_block  # noqa: E402

from mnss_kit.fileio import atomic_directory, atomic_write_json, atomic_write_text, portable_command, read_json  # noqa: E402

DOC = REPO / "docs" / "training.md"
JSON = REPO / "benchmarks" / "results" / "finetune_example.json"
BLOCK = "finetune-example"
DATA_CONFIG = "studio_x2"
MODEL = "mnss_x2"
# fine-tuning settings: a constant, lower learning rate than the shipped run's 3e-4 (its weights are
# already trained), no ground-truth-history warm-up (it teaches a fresh model what history is worth)
TRAIN_SETTINGS = ("train.lr=1.0e-4", "train.lr_schedule=constant", "train.gt_history_epochs=0", "train.val_data=null",
                  "train.threads=1")
METHODS = {"fine-tuned": ("finetuned.json", "model"), MODEL + " (shipped)": ("shipped.json", "model"),
           "TAAU": ("finetuned.json", "taau"), "bicubic": ("finetuned.json", "bicubic")}


def step(number: int, name: str, message: str) -> None:
    print(f"[{number}/7] {name}: {message}", file=sys.stderr, flush=True)


class Steps:
    """The commands run and their times, kept in ``path`` so a resumed run still reports the steps it skips."""

    def __init__(self, path: Path):
        self.path = path
        self.ran = read_json(path) if path.is_file() else {}

    def record(self, key: str, command: str, seconds: float) -> None:
        """A step run again continues its earlier run (render resumes, train --resume): its time adds up
        and the command that started it stays."""
        earlier = self.ran.get(key) or {"command": command, "seconds": 0.0}
        self.ran[key] = {"command": earlier["command"], "seconds": earlier["seconds"] + seconds}
        atomic_write_json(self.path, self.ran)


def mnss_kit(argv: list[str], steps: Steps, key: str) -> None:
    """Run one ``mnss-kit`` command in this process and record it as a user would type it."""
    from mnss_kit.cli import main

    start = time.perf_counter()
    code = main(argv)
    if code != 0:
        raise SystemExit(f"mnss-kit {' '.join(argv)} failed (exit {code})")
    steps.record(key, "mnss-kit " + portable_command(argv), time.perf_counter() - start)


def render(frames: int | None, steps: Steps) -> list[Path]:
    step(1, "render", f"{DATA_CONFIG} -> render")
    mnss_kit(["render", DATA_CONFIG, "--out", "render", *(["--set", f"frames={frames}"] if frames else [])], steps, "render")
    from mnss_kit.render.config import load_render_config

    return [Path("render") / s.name for s in load_render_config(DATA_CONFIG).sequences]


def capture(rendered: list[Path], steps: Steps) -> None:
    from mnss_kit.dataset.nss_export import export_nss

    out = Path("capture")
    if out.is_dir():
        return step(2, "capture", f"{out} exists, skipped")
    step(2, "capture", f"{len(rendered)} sequences as an NSS capture -> {out}")
    start = time.perf_counter()
    export_nss(rendered, out, progress=lambda name: step(2, "capture", f"sequence {name} written"))
    listed = ", ".join(f"'{p.as_posix()}'" for p in rendered)
    steps.record("capture", f"python -c \"from mnss_kit.dataset.nss_export import export_nss; export_nss([{listed}], '{out}')\"",
                 time.perf_counter() - start)


def import_capture(steps: Steps) -> Path:
    out = Path("imported")
    if out.is_dir():
        step(3, "import", f"{out} exists, skipped")
    else:
        step(3, "import", f"capture -> {out}")
        mnss_kit(["data", "import", "nss", "capture", "--out", str(out)], steps, "import")
    return out / "x2"


def split(dataset: Path, held_out: int) -> tuple[list[Path], Path]:
    """``(fine-tune sequence dirs, held-out directory)``: the held-out directory links to the last ``held_out``
    sequences, so one ``eval --data`` covers them."""
    from mnss_kit.dataset.format import find_sequences

    sequences = find_sequences(dataset)
    if not 0 < held_out < len(sequences):
        raise SystemExit(f"--held-out {held_out}: the capture has {len(sequences)} sequences")
    tune, test = sequences[:-held_out], sequences[-held_out:]
    heldout = Path("heldout")
    if not heldout.is_dir():
        with atomic_directory(heldout) as staging:
            for seq in test:  # relative links: valid after the staging directory is renamed
                (staging / seq.name).symlink_to(os.path.relpath(seq, heldout))
    step(4, "split", f"fine-tune on {', '.join(s.name for s in tune)}; held out: {', '.join(s.name for s in test)}")
    return tune, heldout


def train(tune: list[Path], minutes: float, steps: Steps) -> Path:
    run = Path("run")
    final = run / "model.pt"
    if final.is_file():
        step(5, "train", f"{final} exists, skipped")
        return final
    data = "[" + ",".join(s.as_posix() for s in tune) + "]"
    settings = [f"train.train_data={data}", f"train.time_budget_min={minutes:g}", *TRAIN_SETTINGS]
    start = ["--resume"] if (run / "last.pt").is_file() else ["--init", MODEL]  # a killed run continues
    step(5, "train", f"{MODEL} {' '.join(start)}, {minutes:g} min -> {run}")
    mnss_kit(["train", MODEL, *start, "--out", str(run), *[a for s in settings for a in ("--set", s)]], steps, "train")
    return final


def evaluate(model: Path, heldout: Path, steps: Steps) -> None:
    jobs = {"finetuned.json": (str(model), ["model", "bicubic", "taau"]), "shipped.json": (MODEL, ["model"])}
    for name, (checkpoint, methods) in jobs.items():
        out = Path("eval") / name
        if out.is_file() and out.stat().st_mtime > model.stat().st_mtime:  # else it scored an earlier model.pt
            step(6, "eval", f"{out} exists, skipped")
            continue
        step(6, "eval", f"{checkpoint} ({', '.join(methods)}) on {heldout}")
        mnss_kit(["eval", checkpoint, "--data", str(heldout), "--methods", *methods, "--json", str(out)], steps, f"eval {name}")


def collect(rendered: list[str], tune: list[Path], minutes: float, ran: dict) -> dict:
    """The report: the held-out means per method and sequence, what was trained, the commands and their times."""
    from mnss_kit.model.checkpoint import read_record

    evals = {name: read_json(Path("eval") / name) for name in {f for f, _ in METHODS.values()}}
    record, _ = read_record(Path("run") / "model.pt")

    def metrics(stats: dict) -> dict:
        return {k: stats[k] for k in ("psnr", "ssim", "if_ssim")}

    first = evals["finetuned.json"]
    return {
        "data_config": DATA_CONFIG,
        "model": MODEL,
        "fine_tune_sequences": [s.name for s in tune],
        "held_out_sequences": {name: seq["frames"] for name, seq in first["sequences"].items()},
        "held_out_frames": first["frames"],
        "rendered_as": {f"{k:04d}": name for k, name in enumerate(rendered)},  # capture sequence -> studio_x2 sequence
        "training": {"minutes": minutes, "settings": list(TRAIN_SETTINGS)} | {
            k: record["training"][k] for k in ("steps", "wall_time_s", "steps_per_second", "final_loss", "stopped")},
        "methods": {label: metrics(evals[f]["methods"][m]) for label, (f, m) in METHODS.items()},
        "sequences": {seq: {label: metrics(evals[f]["sequences"][seq]["methods"][m]) for label, (f, m) in METHODS.items()}
                      for seq in first["sequences"]},
        "steps": ran,
    }


def _f(value, digits: int, sign: str = "") -> str:
    return "n/a" if value is None else f"{value:{sign}.{digits}f}"


def doc_block(report: dict) -> str:
    """The generated block of docs/training.md, from the report alone."""
    m, t = report["methods"], report["training"]
    tuned, shipped = m["fine-tuned"], m[report["model"] + " (shipped)"]
    gain = tuned["psnr"] - shipped["psnr"]
    verdict = (f"Fine-tuning gained {gain:+.2f} dB PSNR over the shipped weights on the held-out sequences"
               if gain > 0 else f"Fine-tuning did not beat the shipped weights on the held-out sequences ({gain:+.2f} dB PSNR)")
    names = list(report["sequences"])
    named = report["rendered_as"]
    lines = [
        "Generated by `python scripts/finetune_example.py --doc-only` from `benchmarks/results/finetune_example.json`, "
        "which `nice -n 10 python scripts/finetune_example.py` writes.",
        "",
        f"Fine-tuned on {', '.join(f'{n} ({named[n]})' for n in report['fine_tune_sequences'])}; held out: "
        f"{', '.join(f'{n} ({named[n]}, {f} frames)' for n, f in report['held_out_sequences'].items())}.  "
        f"{t['minutes']:g} min of training (`{t['stopped']}`): {t['steps']} steps at {t['steps_per_second']:.2f} steps/s "
        f"on one CPU thread, settings {', '.join(f'`{s}`' for s in t['settings'])}.",
        "",
        "| method | PSNR | SSIM | IF-SSIM | " + " | ".join(f"PSNR {n}" for n in names) + " |",
        "|---|---|---|---|" + "---|" * len(names),
    ]
    for label, stats in m.items():
        per_seq = " | ".join(f"{report['sequences'][n][label]['psnr']:.2f}" for n in names)
        lines.append(f"| {label} | {stats['psnr']:.2f} | {stats['ssim']:.4f} | {_f(stats['if_ssim'], 4)} | {per_seq} |")
    lines += ["", f"{verdict}; SSIM {tuned['ssim'] - shipped['ssim']:+.4f}, IF-SSIM "
              f"{_f(_delta(tuned['if_ssim'], shipped['if_ssim']), 4, '+')}.  Against TAAU: "
              f"{tuned['psnr'] - m['TAAU']['psnr']:+.2f} dB fine-tuned, {shipped['psnr'] - m['TAAU']['psnr']:+.2f} dB shipped.",
              "", f"Commands run, {sum(s['seconds'] for s in report['steps'].values()) / 60:.1f} min in all "
              "(times on a CPU shared with other work):", ""]
    lines += [f"    {s['command']}    # {s['seconds'] / 60:.1f} min" for s in report["steps"].values()]
    return "\n".join(lines)


def _delta(a, b):
    return None if a is None or b is None else a - b


def write_doc(report: dict, doc: Path = DOC) -> None:
    atomic_write_text(doc, replace_block(doc.read_text(), BLOCK, doc_block(report), doc))


def run(args: argparse.Namespace) -> None:
    work = args.work.resolve()
    work.mkdir(parents=True, exist_ok=True)
    os.chdir(work)  # every command names its files relative to WORK, so the report names no machine path
    steps = Steps(Path("steps.json"))
    rendered = render(args.frames, steps)
    capture(rendered, steps)
    tune, heldout = split(import_capture(steps), args.held_out)
    model = train(tune, args.minutes, steps)
    evaluate(model, heldout, steps)
    report = collect([p.name for p in rendered], tune, args.minutes, steps.ran)
    atomic_write_json(JSON, report)
    step(7, "report", f"{JSON.relative_to(REPO)}")
    write_doc(report)
    step(7, "report", f"{DOC.relative_to(REPO)} updated")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=REPO / "runs" / "finetune_example", help="directory for every step's output")
    parser.add_argument("--minutes", type=float, default=10.0, help="training time of the fine-tune (train.time_budget_min)")
    parser.add_argument("--frames", type=int, default=None, help=f"frames per sequence (default: {DATA_CONFIG}'s); for a quick trial")
    parser.add_argument("--held-out", type=int, default=2, help="how many of the capture's last sequences are held out")
    parser.add_argument("--doc-only", action="store_true", help=f"only rewrite the doc block from {JSON.relative_to(REPO)}")
    args = parser.parse_args(argv)
    if args.doc_only:
        write_doc(read_json(JSON))
    else:
        run(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
