#!/usr/bin/env python
"""A checkpoint at the quality modes (issue 44): the held-out set ``test_x2`` rendered at 1.3, 1.5,
1.7, 2, 2.5 and 3, and the unseen set ``unseen_x2`` at 1.5 and 3, each evaluated with
``mnss-kit eval --scale S``.  Writes one eval JSON per set and mode and ``modes.json`` (the
per-method means of every entry) into OUT.

    python scripts/eval_modes.py runs/ntaau_lr_modes/model.pt --out benchmarks/results/modes
    python scripts/eval_modes.py none --out /tmp/modes --sets test_x2=1.5,3 --max-frames 24

Each set is rendered by ``--scale`` overrides of its config (``mnss-kit render CONFIG --scale S
--out DATA_ROOT/CONFIG_xS``; an existing directory is reused): the configs give ``lr_size:
[320, 180]``, and 320x180 times each of these modes is a whole number of HR pixels on both axes
(416x234, 480x270, 544x306, 640x360, 800x450, 960x540), so every mode's ratio is exactly its
scale.  The grid jitter pattern exists at 2 and 3 only: a fractional mode renders with Halton
jitter (``--jitter`` sets one pattern for every mode).  ``--set KEY=VALUE`` passes further render
overrides (``frames=24``, ``hr_samples=4``).  Renders are slow (16 HR samples, the native TAA and
4x references; 3x renders 960x540): render once, evaluate many checkpoints.

A checkpoint of a family that reads the frame key ``scale`` (docs/architecture.md) runs at every
mode; one of another family only at its own scale (eval refuses the others in one line, and the
entry records the refusal).  ``none`` evaluates the baselines alone.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mnss_kit.cli import main as cli  # noqa: E402
from mnss_kit.errors import UserError  # noqa: E402
from mnss_kit.fileio import atomic_write_json  # noqa: E402
from mnss_kit.ops.scale import is_integer, parse_scale, scale_label  # noqa: E402

MODES = {"test_x2": (1.3, 1.5, 1.7, 2, 2.5, 3), "unseen_x2": (1.5, 3)}


def parse_sets(items: list[str] | None) -> dict[str, tuple]:
    """``["test_x2=1.5,3", "unseen_x2"]`` -> ``{"test_x2": (1.5, 3), "unseen_x2": (1.5, 3)}`` (a set
    without modes takes its default ones; a config not in MODES needs them)."""
    if not items:
        return dict(MODES)
    sets = {}
    for item in items:
        name, _, modes = item.partition("=")
        if modes:
            sets[name] = tuple(parse_scale(m, f"--sets {name}") for m in modes.split(","))
        elif name in MODES:
            sets[name] = MODES[name]
        else:
            raise UserError(f"--sets {name}: give its modes (e.g. {name}=1.5,3)")
    return sets


def render_overrides(scale, jitter: str | None, extra: list[str]) -> list[str]:
    """``--set`` arguments of one mode's render."""
    pattern = jitter or (None if is_integer(scale) else "halton")
    sets = [f"jitter={pattern}"] if pattern else []
    return [a for o in [*sets, *extra] for a in ("--set", o)]


def run_mode(model: str, config: str, scale, args) -> dict:
    label = scale_label(scale)
    data = args.data_root / f"{Path(config).stem}_{label}"
    out_json = args.out / f"{Path(config).stem}_{label}.json"
    entry = {"set": Path(config).stem, "scale": scale, "data": str(data), "json": str(out_json)}
    if not data.exists():
        render = ["render", config, "--scale", str(scale), "--out", str(data), *render_overrides(scale, args.jitter, args.set)]
        if args.no_progress:
            render.append("--no-progress")
        if cli(render) != 0:
            return {**entry, "error": f"render failed: mnss-kit {' '.join(render)}"}
    evaluate = ["eval", model, "--data", str(data), "--scale", str(scale), "--json", str(out_json),
                "--reference", args.reference]
    if args.max_frames:
        evaluate += ["--max-frames", str(args.max_frames)]
    if args.no_progress:
        evaluate.append("--no-progress")
    if out_json.exists():
        out_json.unlink()  # eval refuses to overwrite; a new run of the script evaluates again
    if cli(evaluate) != 0:  # the CLI prints the one-line reason (e.g. a model of another scale)
        return {**entry, "error": f"eval failed: mnss-kit {' '.join(evaluate)}"}
    result = json.loads(out_json.read_text())
    entry["methods"] = {name: {k: stats[k] for k in ("psnr", "ssim", "if_ssim") if k in stats}
                        for name, stats in result["methods"].items()}
    entry["frames"] = result.get("frames")
    return entry


def run(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", help="checkpoint path, shipped name, or 'none' (the baselines only)")
    parser.add_argument("--out", type=Path, required=True, help="directory for the eval JSONs and modes.json")
    parser.add_argument("--data-root", type=Path, default=Path("data/modes"),
                        help="where each set and mode is rendered (default: data/modes)")
    parser.add_argument("--sets", nargs="+", metavar="CONFIG[=S,S]",
                        help="data configs and their modes (default: test_x2=1.3,1.5,1.7,2,2.5,3 unseen_x2=1.5,3)")
    parser.add_argument("--jitter", help="one jitter pattern for every mode (default: the config's, halton at fractional modes)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a further render override")
    parser.add_argument("--reference", default="box", choices=("box", "taa", "4x"), help="eval --reference (default: box)")
    parser.add_argument("--max-frames", type=int, help="evaluate at most N frames of each sequence")
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    try:
        sets = parse_sets(args.sets)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    entries = [run_mode(args.model, config, scale, args) for config, modes in sets.items() for scale in modes]
    summary = {"model": args.model, "reference": args.reference, "max_frames": args.max_frames, "entries": entries}
    atomic_write_json(args.out / "modes.json", summary)
    for e in entries:
        means = "; ".join(f"{name} {m['psnr']:.2f} dB" for name, m in e.get("methods", {}).items() if "psnr" in m)
        print(f"{e['set']} {scale_label(e['scale'])}: {means or e.get('error')}")
    failed = [e for e in entries if "error" in e]
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(run())
