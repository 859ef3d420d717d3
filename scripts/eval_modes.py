#!/usr/bin/env python
"""A checkpoint at the quality modes (issue 44): the held-out set ``test_x2`` rendered at 1.3, 1.5,
1.7, 2, 2.5 and 3, and the unseen set ``unseen_x2`` at 1.5 and 3, each evaluated with
``mnss-kit eval --scale S``.  Writes one eval JSON per set and mode and ``modes.json`` (the
per-method means of every entry) into OUT.

    python scripts/eval_modes.py ntaau_lr_modes --out benchmarks/results/modes --compare ntaau_lr_x2
    python scripts/eval_modes.py none --out /tmp/modes --sets test_x2=1.5,3 --max-frames 24

Each set is rendered by ``--scale`` overrides of its config (``mnss-kit render CONFIG --scale S
--out DATA_ROOT/CONFIG_xS``; the frames present are kept, so pass the same ``--set frames=N``
as the first run): the configs give ``lr_size:
[320, 180]``, and 320x180 times each of these modes is a whole number of HR pixels on both axes
(416x234, 480x270, 544x306, 640x360, 800x450, 960x540), so every mode's ratio is exactly its
scale.  The grid jitter pattern exists at 2 and 3 only: a fractional mode renders with Halton
jitter (``--jitter`` sets one pattern for every mode).  Each mode is evaluated in two input
variants (``--variants``): that jittered render, and a render without jitter rewritten with
8-bit colour and depth (``DATA_ROOT/CONFIG_xS_center``, then ``..._no_jitter_ldr8_depth8``), as a
game capture comes.  ``--set KEY=VALUE`` passes further render
overrides (``frames=24``, ``hr_samples=4``).  Renders are slow (16 HR samples, the native TAA and
4x references; 3x renders 960x540): render once, evaluate many checkpoints.

A checkpoint of a family that reads the frame key ``scale`` (docs/architecture.md) runs at every
mode; one of another family only at its own scale (eval refuses the others in one line, and the
entry records the refusal).  ``none`` evaluates the baselines alone.

``--doc FILE`` also writes the quality-mode table: per set and mode the model's PSNR / SSIM /
IF-SSIM against TAAU and bicubic, and per mode the render cost saved and the estimated frame ms on
each device profile (``mnss-kit split --scale S``).  ``--doc-only`` writes it from OUT/modes.json
without evaluating again::

    python scripts/eval_modes.py --out benchmarks/results/modes --doc-only --doc docs/modes.md
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mnss_kit.bench.run import quality_table as eval_quality  # noqa: E402
from mnss_kit.cli import main as cli  # noqa: E402
from mnss_kit.errors import UserError  # noqa: E402
from mnss_kit.fileio import atomic_write_json, atomic_write_text, portable_path, read_json  # noqa: E402
from mnss_kit.ops.jitter import GRID_SCALES  # noqa: E402
from mnss_kit.ops.scale import is_integer, lr_size_for, parse_scale, scale_label  # noqa: E402
from mnss_kit.split.inputs import DEFAULT_RESOLUTION, DEFAULT_RESOLUTION_TEXT  # noqa: E402

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
    pattern = jitter or (None if scale in GRID_SCALES else "halton")
    sets = [f"jitter={pattern}"] if pattern else []
    return [a for o in [*sets, *extra] for a in ("--set", o)]


# Input variants per mode: "jittered" renders each mode with the config's jitter (Halton at the
# fractional modes, where the grid pattern does not exist); the others as eval.variant_sets defines them.
JITTERED = "jittered"
MODE_VARIANTS = (JITTERED, "no_jitter_ldr8_depth8")


def variant_data(config: str, scale, variant: str, args) -> tuple[Path, str | None]:
    """The directory of ``config`` at ``scale`` in ``variant`` and an error line when a step failed.
    The render always runs: it skips the frames present and completes an interrupted one."""
    from mnss_kit.eval.variant_sets import VARIANTS, rewritten

    base = args.data_root / f"{Path(config).stem}_{scale_label(scale)}"
    pattern, applied = (args.jitter, []) if variant == JITTERED else VARIANTS[variant][:2]
    rendered = base if variant == JITTERED else base.with_name(f"{base.name}_{pattern}")
    render = ["render", config, "--scale", str(scale), "--out", str(rendered), *render_overrides(scale, pattern, args.set)]
    if args.no_progress:
        render.append("--no-progress")
    if cli(render) != 0:
        return rendered, f"render failed: mnss-kit {' '.join(render)}"
    if not applied:
        return rendered, None
    return rewritten(rendered, base.with_name(f"{base.name}_{variant}"), list(applied)), None


def run_mode(model: str, config: str, scale, variant: str, args) -> dict:
    label = scale_label(scale)
    suffix = "" if variant == JITTERED else f"_{variant}"
    out_json = args.out / f"{Path(config).stem}_{label}{suffix}.json"
    data, error = variant_data(config, scale, variant, args)
    entry = {"set": Path(config).stem, "scale": scale, "variant": variant, "data": str(data), "json": str(out_json)}
    if error:
        return {**entry, "error": error}
    evaluate = eval_command(model, data, scale, out_json, args)
    result = evaluated(evaluate, out_json, args.resume)
    if result is None:  # the CLI printed the one-line reason (e.g. a model of another scale)
        return {**entry, "error": f"eval failed: mnss-kit {' '.join(evaluate)}"}
    entry.update(eval_quality(result, result["methods"]), frames=result.get("frames"))
    if args.compare and float(args.compare_scale) == float(scale):
        compare_json = out_json.with_name(f"{out_json.stem}_compare.json")
        compared = evaluated(eval_command(args.compare, data, scale, compare_json, args, ["model"]), compare_json, args.resume)
        if compared is not None:
            entry["compare"] = {"model": args.compare, **eval_quality(compared, ["model"])["methods"]["model"]}
    return entry


def eval_command(model: str, data: Path, scale, out_json: Path, args, methods: list[str] | None = None) -> list[str]:
    """The ``mnss-kit eval`` arguments of one mode (``methods``: eval's default when None)."""
    command = ["eval", model, "--data", str(data), "--scale", str(scale), "--json", str(out_json),
               "--reference", args.reference]
    if methods:
        command += ["--methods", *methods]
    if args.max_frames:
        command += ["--max-frames", str(args.max_frames)]
    if args.no_progress:
        command.append("--no-progress")
    return command


def trained_scales(model: str) -> list:
    """The scales of the checkpoint's training data (from its record and the data's meta.json; empty
    when the data is not on this machine)."""
    from mnss_kit.model.checkpoint import read_record
    from mnss_kit.train.run import data_scales

    if model == "none":
        return []
    dirs = [REPO / d for d in (read_record(model)[0].get("train") or {}).get("train_data") or []]
    return data_scales([d for d in dirs if d.is_dir()])


def evaluated(command: list[str], out_json: Path, resume: bool) -> dict | None:
    """``mnss-kit eval`` (``command``) writing ``out_json``, or the JSON already there with ``resume``
    when it was made by the same command; None when eval failed."""
    made_by = {"command": command, "checkpoint": checkpoint_digest(command[1])}
    if resume and out_json.is_file():
        result = json.loads(out_json.read_text())
        if result.get("made_by") == made_by:
            return result
    if out_json.exists():
        out_json.unlink()  # eval refuses to overwrite; a new run of the script evaluates again
    if cli(command) != 0:
        return None
    result = json.loads(out_json.read_text())
    atomic_write_json(out_json, {**result, "made_by": made_by})
    return result


def checkpoint_digest(model: str) -> str | None:
    """The sha256 of checkpoint ``model`` (None for ``none``): a retrained file is another model."""
    from mnss_kit.model.checkpoint import digest

    return None if model == "none" else digest(model)


def own_scale(model: str):
    """The scale checkpoint ``model`` was made for (a 2x-only model's 2)."""
    from mnss_kit.split.inputs import load_model

    return load_model(model)[0].scale


UNTRAINED_SLACK_DB = 0.2  # an untrained mode's margin against its trained neighbours' mean
COMPARE_SLACK_DB = 0.1  # what the modes checkpoint may lose against a single-scale one at its scale
QUALITY = (("psnr", 2), ("ssim", 4), ("if_ssim", 4))  # each cell's metrics, with their decimals
COMPARED = (("model", "model"), ("taau", "TAAU"), ("bicubic", "bicubic"))  # eval's method names, as the page names them


def render_fraction(scale) -> tuple[tuple[int, int], float]:
    """The LR size of the split's default output size at ``scale`` and LR pixels / HR pixels: the
    share of the pixels the renderer still shades."""
    lr = lr_size_for(DEFAULT_RESOLUTION, scale)
    return lr, lr[0] * lr[1] / (DEFAULT_RESOLUTION[0] * DEFAULT_RESOLUTION[1])


def estimated_ms(model: str, scales) -> dict:
    """Per scale, the estimated frame ms of ``model``'s default placement on each device profile at
    the default output size (``mnss-kit split --scale S``; None where the model cannot run at it)."""
    from mnss_kit.bench.run import device_estimates
    from mnss_kit.model.families import run_at_scale
    from mnss_kit.split.device import device_names
    from mnss_kit.split.inputs import load_model

    loaded, _ = load_model(model)
    estimates = {}
    for scale in dict.fromkeys(scales):
        try:
            run_at_scale(loaded, scale)
        except UserError:  # a family of integer scales runs at its own only (eval refused the others too)
            estimates[scale] = None
            continue
        estimates[scale] = device_estimates(loaded, tuple(device_names()), DEFAULT_RESOLUTION)
    return estimates


def quality_table(entries: list[dict]) -> list[str]:
    """One set: per mode PSNR / SSIM / IF-SSIM of the model, TAAU and bicubic, and the model's margin over TAAU."""
    shown = [(key, name) for key, name in COMPARED if any(key in e.get("methods", {}) for e in entries)]
    margin = any("model" in e.get("methods", {}) for e in entries)
    compared = next((e["compare"]["model"] for e in entries if "compare" in e), None)
    header = ["mode", "frames", *(name for _, name in shown)]
    header += ["model - TAAU", "sequences below TAAU"] if margin else []
    header += [f"`{portable_path(compared)}` (PSNR)"] if compared else []
    lines = ["| " + " | ".join(header) + " |", "|---|" + "---:|" * (len(header) - 1)]
    for e in entries:
        methods = e.get("methods", {})
        if not methods:
            lines.append(f"| {scale_label(e['scale'])} | not evaluated: {e.get('error', '').split(':')[0]} |")
            continue
        cells = [scale_label(e["scale"]), str(e.get("frames", ""))]
        cells += [_scores(methods.get(key, {})) for key, _ in shown]
        if margin:
            cells.append(_margins(methods.get("model", {}), methods.get("taau", {})))
            below = below_taau(e)
            cells.append(", ".join(f"{seq} ({gap:+.2f} dB)" for seq, gap in below.items()) or "none")
        if compared:
            cells.append(f"{e['compare']['psnr']:.2f}" if "compare" in e else "-")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def below_taau(entry: dict) -> dict[str, float]:
    """The sequences whose model PSNR is below TAAU's, with the gap (dB)."""
    gaps = {seq: m["model"]["psnr"] - m["taau"]["psnr"] for seq, m in entry.get("sequences", {}).items()
            if "model" in m and "taau" in m}
    return {seq: gap for seq, gap in gaps.items() if gap < 0}


def margin_of(entry: dict) -> float | None:
    methods = entry.get("methods", {})
    return methods["model"]["psnr"] - methods["taau"]["psnr"] if "model" in methods and "taau" in methods else None


def checks(summary: dict) -> list[str]:
    """The issue's floors per set and variant: no sequence below TAAU at any mode; an untrained mode's
    margin within UNTRAINED_SLACK_DB of the mean of its neighbouring trained modes'; at the compared
    model's scale, at most COMPARE_SLACK_DB below it."""
    trained = summary.get("trained_scales") or []
    lines = []
    groups: dict = {}
    for e in summary["entries"]:
        groups.setdefault((e["set"], e.get("variant", JITTERED)), []).append(e)
    for (set_name, variant), entries in groups.items():
        margins = {e["scale"]: m for e in entries if (m := margin_of(e)) is not None}
        if not margins:
            continue
        below = [f"{scale_label(e['scale'])}: {', '.join(seqs)}" for e in entries if (seqs := below_taau(e))]
        lines.append(f"- `{set_name}`, {VARIANT_SHORT.get(variant, variant)}: "
                     + (f"below TAAU on {'; '.join(below)} (missed)" if below else "no sequence below TAAU at any mode (met)"))
        lines += untrained_checks(margins, trained)
        for e in entries:
            if "compare" in e and "model" in e.get("methods", {}):
                gap = e["methods"]["model"]["psnr"] - e["compare"]["psnr"]
                lines.append(f"  - {scale_label(e['scale'])}: {gap:+.2f} dB against `{portable_path(e['compare']['model'])}` "
                             f"on the same frames (at least -{COMPARE_SLACK_DB}: {'met' if gap >= -COMPARE_SLACK_DB else 'missed'})")
    if trained:
        lines.append(f"- Trained modes: {', '.join(scale_label(t) for t in trained)} (the checkpoint's training data).")
    return ["## Checks", "", *lines, ""] if lines else []


def untrained_checks(margins: dict, trained: list) -> list[str]:
    """Each untrained mode's margin against the mean of its nearest trained modes' on either side."""
    lines = []
    for scale in (s for s in margins if trained and s not in trained):
        neighbours = [t for t in (max((t for t in trained if t < scale), default=None),
                                  min((t for t in trained if t > scale), default=None)) if t in margins]
        if not neighbours:
            continue
        mean = sum(margins[t] for t in neighbours) / len(neighbours)
        ok = abs(margins[scale] - mean) <= UNTRAINED_SLACK_DB
        lines.append(f"  - untrained {scale_label(scale)}: margin {margins[scale]:+.2f} dB against "
                     f"{mean:+.2f} for {' and '.join(scale_label(t) for t in neighbours)} "
                     f"(within {UNTRAINED_SLACK_DB} dB: {'met' if ok else 'missed'})")
    return lines


def cost_table(scales, estimates: dict) -> list[str]:
    """Per mode the LR size, LR / HR pixels and the estimated ms on each device profile."""
    devices = list(next((e for e in estimates.values() if e), {}))
    header = ["mode", f"LR size at {DEFAULT_RESOLUTION_TEXT}", "LR / HR pixels"] + [f"{d} ms (est.)" for d in devices]
    lines = ["| " + " | ".join(header) + " |", "|---|" + "---:|" * (len(header) - 1)]
    for scale in dict.fromkeys(scales):
        (lw, lh), fraction = render_fraction(scale)
        ms = estimates.get(scale) or {}
        cells = [scale_label(scale), f"{lw}x{lh}", f"{fraction:.3f}"] + [f"{ms[d]:.2f}" if d in ms else "-" for d in devices]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def doc_lines(summary: dict, source: str, estimates: dict) -> list[str]:
    """The page: what it is from, one quality table per set, one cost table."""
    model = summary["model"]
    name = "no model (the baselines)" if model == "none" else f"`{portable_path(model)}`"  # a shipped name stays as it is
    frames = f"the first {summary['max_frames']} frames of each sequence" if summary.get("max_frames") else "every frame"
    sets = {}
    for e in summary["entries"]:
        sets.setdefault((e["set"], e.get("variant", JITTERED)), []).append(e)
    lines = [f"# Quality modes: {name} against TAAU and bicubic", "",
             f"Generated by `scripts/eval_modes.py` from `{source}`; do not edit by hand.", "",
             f"Model: {name}.  Reference: `{summary['reference']}` (`mnss-kit eval --reference`).  Frames: {frames} "
             "(the frames column counts those each mode was evaluated on).  Each mode is its set rendered at that "
             "scale (`mnss-kit render --scale S`) and evaluated with `mnss-kit eval --scale S`; the margin is the "
             "model's over TAAU.  Each cell: PSNR (dB) / SSIM / IF-SSIM.", ""]
    lines += checks(summary)
    for (set_name, variant), entries in sets.items():
        lines += [f"## `{set_name}`, {VARIANT_TITLES.get(variant, variant)}", "", *quality_table(entries), ""]
    lines += ["## Cost per mode", "",
              f"At {DEFAULT_RESOLUTION_TEXT} output: the LR size the renderer shades (round(WxH / S) per axis), its share of "
              "the output's pixels (the render cost left; 1 minus it is saved), and the estimated frame milliseconds of "
              "the model's default GPU/NPU placement on each device profile under `mnss_kit/configs/devices/` "
              "(`mnss-kit split --scale S`): estimates from the profiles, not measurements.  The same in every set.", "",
              *cost_table([e["scale"] for e in summary["entries"]], estimates), ""]
    return lines + rounding_note(summary)


VARIANT_SHORT = {JITTERED: "jittered", "no_jitter_ldr8_depth8": "no jitter, 8-bit"}
VARIANT_TITLES = {JITTERED: "jittered (the grid pattern at 2x and 3x, Halton at the fractional modes)",
                  "no_jitter_ldr8_depth8": "no jitter, 8-bit colour and depth"}


def rounding_note(summary: dict) -> list[str]:
    """A line for integer modes that do not divide the output size (x3 at 1280x720), which `mnss-kit split`
    refuses: their LR size rounds here as a quality mode's does."""
    odd = [s for s in dict.fromkeys(e["scale"] for e in summary["entries"])
           if is_integer(s) and any(v % int(s) for v in DEFAULT_RESOLUTION)]
    if not odd:
        return []
    return [f"{', '.join(scale_label(s) for s in odd)}: {DEFAULT_RESOLUTION_TEXT} is not a whole number of LR pixels, so "
            "the LR size rounds as at a quality mode (`mnss-kit split` asks for a multiple of an integer scale).", ""]


def write_doc(summary: dict, path: Path, source: str) -> None:
    """The quality-mode page for ``summary`` (modes.json) at ``path``; ``source`` names modes.json."""
    scales = [e["scale"] for e in summary["entries"]]
    estimates = {} if summary["model"] == "none" else estimated_ms(summary["model"], scales)
    atomic_write_text(path, "\n".join(doc_lines(summary, source, estimates)))
    print(f"wrote {portable_path(path)}")


def _scores(stats: dict) -> str:
    """``PSNR / SSIM / IF-SSIM`` of one method (``-`` for a metric it lacks)."""
    return " / ".join(f"{stats[m]:.{d}f}" if m in stats else "-" for m, d in QUALITY)


def _margins(model: dict, taau: dict) -> str:
    return " / ".join(f"{model[m] - taau[m]:+.{d}f}" if m in model and m in taau else "-" for m, d in QUALITY)


def run(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", nargs="?", help="checkpoint path, shipped name, or 'none' (the baselines only; "
                        "not with --doc-only, which takes the one modes.json names)")
    parser.add_argument("--out", type=Path, required=True, help="directory for the eval JSONs and modes.json")
    parser.add_argument("--data-root", type=Path, default=Path("data/modes"),
                        help="where each set and mode is rendered (default: data/modes)")
    parser.add_argument("--sets", nargs="+", metavar="CONFIG[=S,S]",
                        help="data configs and their modes (default: test_x2=1.3,1.5,1.7,2,2.5,3 unseen_x2=1.5,3)")
    parser.add_argument("--jitter", help="one jitter pattern for every mode of the jittered variant (default: the config's, halton at fractional modes)")
    parser.add_argument("--variants", nargs="+", default=list(MODE_VARIANTS), choices=MODE_VARIANTS,
                        help="input variants per mode (default: both)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a further render override")
    parser.add_argument("--reference", default="box", choices=("box", "taa", "4x"), help="eval --reference (default: box)")
    parser.add_argument("--max-frames", type=int, help="evaluate at most N frames of each sequence")
    parser.add_argument("--no-progress", action="store_true")
    parser.add_argument("--compare", metavar="CHECKPOINT", help="also evaluate this model at its own scale (a 2x-only one at 2x) on the same frames")
    parser.add_argument("--resume", action="store_true", help="keep the eval JSONs in OUT made by the same command and "
                        "checkpoint, and modes.json's entries of the sets not run again")
    parser.add_argument("--doc", type=Path, metavar="FILE", help="also write the quality-mode table (markdown) to FILE")
    parser.add_argument("--doc-only", action="store_true", help="write --doc from OUT/modes.json (and the model it names) without evaluating")
    args = parser.parse_args(argv)
    try:
        if args.doc_only:
            return write_doc_only(args)
        if not args.model:
            raise UserError("give the model to evaluate (a checkpoint, a shipped name or 'none')")
        sets = parse_sets(args.sets)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    args.compare_scale = own_scale(args.compare) if args.compare else None  # loaded once, not per mode
    entries = [run_mode(args.model, config, scale, variant, args)
               for config, modes in sets.items() for variant in args.variants for scale in modes]
    if args.resume:
        entries = earlier_entries(args, entries) + entries
    summary = {"model": args.model, "reference": args.reference, "max_frames": args.max_frames,
               "trained_scales": trained_scales(args.model), "entries": entries}
    atomic_write_json(args.out / "modes.json", summary)
    for e in entries:
        means = "; ".join(f"{name} {m['psnr']:.2f} dB" for name, m in e.get("methods", {}).items() if "psnr" in m)
        print(f"{e['set']} {scale_label(e['scale'])} {e['variant']}: {means or e.get('error')}")
    if args.doc:
        write_doc(summary, args.doc, portable_path(args.out / "modes.json"))
    failed = [e for e in entries if "error" in e]
    return 1 if failed else 0


def earlier_entries(args, entries: list[dict]) -> list[dict]:
    """With --resume, the entries of OUT/modes.json for the same model, reference and frames that this
    run did not evaluate again (another set run earlier into OUT)."""
    path = args.out / "modes.json"
    if not path.is_file():
        return []
    earlier = read_json(path)
    if (earlier.get("reference"), earlier.get("max_frames")) != (args.reference, args.max_frames) or \
            checkpoint_digest(earlier.get("model", "none")) != checkpoint_digest(args.model):
        return []
    now = {(e["set"], e["scale"], e["variant"]) for e in entries}
    return [e for e in earlier.get("entries", []) if (e["set"], e["scale"], e["variant"]) not in now]


def write_doc_only(args) -> int:
    modes = args.out / "modes.json"
    if not args.doc:
        raise UserError("--doc-only needs --doc FILE")
    if not modes.is_file():
        raise UserError(f"no {portable_path(modes)} yet: run without --doc-only first")
    write_doc(read_json(modes), args.doc, portable_path(modes))
    return 0


if __name__ == "__main__":
    sys.exit(run())
