#!/usr/bin/env python
"""The engine judge: the shipped models against the toolkit's TAAU, the FSR2-class upscaler and
bicubic on held-out data as an engine sends it (``eval.variant_sets`` "engine": no jitter, 8-bit
LDR colour, 8-bit reversed depth with a guessed near plane, motion packed in 8-bit pairs, dilated,
rigid on some moving objects and absent on others), scored against the renderer's 16-sample box
and against a native-resolution TAA frame such as an engine's own "ground truth".  Writes
``benchmarks/results/engine_results.json`` and ``docs/results_engine.md``.

    python scripts/engine_results.py                    # test_x2 and unseen_x2 (both references) and the stress scenarios
    python scripts/engine_results.py --sets unseen_x2   # one part; another process may run the others
    python scripts/engine_results.py --doc-only

Resumable: finished set x reference entries are kept (for the same checkpoint files and frame
count).  Every sequence is cut to its first FRAMES frames.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mnss_kit.bench.run import model_label  # noqa: E402
from mnss_kit.eval.variant_sets import VARIANTS, variant_set  # noqa: E402
from mnss_kit.fileio import atomic_write_json, atomic_write_text, read_json  # noqa: E402

import heldout_results  # noqa: E402  (the results file's lock and reader, shared)
from heldout_results import SSIM_SLACK  # noqa: E402  (how far below TAAU's SSIM or IF-SSIM counts as below)
from mnss_kit.zoo import DEFAULT_MODEL  # noqa: E402

RESULTS = REPO / "benchmarks" / "results" / "engine_results.json"
WORK = REPO / "benchmarks" / "results" / "work" / "engine"
CROPS = REPO / "benchmarks" / "results" / "engine_crops"
DOC = REPO / "docs" / "results_engine.md"
FRAMES = 24
SETS = ("test_x2", "unseen_x2")
VARIANT = "engine"
REFERENCES = {"box": "16-sample box reference", "taa": "native TAA reference (ops/native_taa.py)"}
BASELINES = ("taau", "fsr2", "bicubic")
METRICS = (("psnr", "PSNR", "{:.2f}"), ("ssim", "SSIM", "{:.4f}"), ("if_ssim", "IF-SSIM", "{:.4f}"))
STRESS = ("figure_crossing", "foliage_strafe_cut")  # stress.yaml's scenarios of the two failure kinds


# The page's opening line: what the reader can do with it.
LEAD = "Use this page to see how the shipped models do on inputs as a game engine sends them, scored against the renderer's reference and against a native TAA frame, beside TAAU and the FSR2-class upscaler."


def evaluate_entry(models: list[str], data: Path, reference: str, crops: Path | None, max_frames: int | None = FRAMES) -> dict:
    from mnss_kit.eval.baselines import baseline_methods
    from mnss_kit.eval.methods import model_method
    from mnss_kit.eval.loop import evaluate
    from mnss_kit.model.checkpoint import load

    methods = {}
    for name in models:
        model, _ = load(name)
        methods[model_label(name)] = model_method(model.eval())
    methods.update(baseline_methods(2, BASELINES))
    result = evaluate(methods, data, scale=2, max_frames=max_frames, crops_dir=crops, progress=False, reference=reference)
    keys = [k for k, _, _ in METRICS] + ["disocclusion_psnr"]
    pick = lambda stats: {k: stats.get(k) for k in keys}  # noqa: E731
    return {"methods": {m: pick(s) for m, s in result["methods"].items()},
            "sequences": {seq: {m: pick(s) for m, s in info["methods"].items()} for seq, info in result["sequences"].items()},
            "frames_below_taau": frames_below_taau(result["per_frame"], list(methods))}


def frames_below_taau(rows: list[dict], methods: list[str]) -> dict[str, list[int]]:
    """Per method: ``[frames whose PSNR is below TAAU's, frames]``."""
    taau = {(r["sequence"], r["frame"]): r["psnr"] for r in rows if r["method"] == "taau"}
    out = {}
    for m in methods:
        mine = [(r["psnr"], taau[(r["sequence"], r["frame"])]) for r in rows if r["method"] == m]
        out[m] = [sum(1 for a, b in mine if a < b), len(mine)]
    return out


def read_results(models: list[str], digests: list[str]) -> dict:
    from mnss_kit.eval.baselines import baseline_settings

    return heldout_results.read_results(models, digests, RESULTS, FRAMES, baseline_settings())


def results_lock():
    return heldout_results.results_lock(RESULTS)


def run(models: list[str], sets: list[str]) -> dict:
    from mnss_kit.model.checkpoint import digest

    digests = [digest(m) for m in models]
    with results_lock():
        atomic_write_json(RESULTS, read_results(models, digests))
    for config in [c for c in sets if c in SETS]:
        data = None
        for reference in REFERENCES:
            with results_lock():
                if reference in read_results(models, digests)["sets"].get(config, {}):
                    continue
            print(f"{config} / {VARIANT} / {reference}", flush=True)
            data = data or variant_set(VARIANT, config, WORK, FRAMES, progress=True)
            entry = evaluate_entry(models, data, reference, CROPS / f"{config}_{reference}")
            with results_lock():
                doc = read_results(models, digests)
                doc["sets"].setdefault(config, {})[reference] = entry
                atomic_write_json(RESULTS, doc)
    if "stress" in sets and "stress" not in read_results(models, digests):
        print("stress scenarios", flush=True)
        entry = evaluate_entry(models, stress_data(), "box", CROPS / "stress", max_frames=None)
        with results_lock():
            doc = read_results(models, digests)
            doc["stress"] = entry
            atomic_write_json(RESULTS, doc)
    with results_lock():
        return read_results(models, digests)


def stress_data() -> Path:
    """The STRESS scenarios of ``stress.yaml``, rendered as ``mnss-kit stress`` renders them (resumable)."""
    import dataclasses

    from mnss_kit.render.config import load_render_config
    from mnss_kit.render.run import render_dataset

    cfg = load_render_config("stress")
    cfg = dataclasses.replace(cfg, sequences=[s for s in cfg.sequences if s.name in STRESS])
    out = WORK / "stress"
    render_dataset(cfg, out, progress=True)
    return out


def below_lines(doc: dict) -> list[str]:
    """Where the default falls below a baseline (``shortfalls``), per set, reference and sequence, and on
    the stress scenarios."""
    default, lines = doc["labels"][0], []
    for config, reference, entry in entries(doc):
        found = [f for seq, per in entry["sequences"].items() for f in shortfalls(seq, per, default)]
        below, total = entry["frames_below_taau"][default]
        lines.append(f"- `{config}` against the {REFERENCES[reference]}: below on "
                     f"{'; '.join(found) if found else 'no sequence'}; PSNR below TAAU on {below} of {total} frames "
                     f"({100.0 * below / max(total, 1):.0f}%)")
    if "stress" in doc:
        found = [f for seq, per in doc["stress"]["sequences"].items()
                 for f in shortfalls(seq, per, default, ("psnr", "disocclusion_psnr"))]
        lines.append(f"- stress scenarios: below on {'; '.join(found) if found else 'no scenario'}")
    return lines


def shortfalls(seq: str, per: dict, default: str, psnr_keys=("psnr",)) -> list[str]:
    """Where ``default`` is below a baseline on one sequence: PSNR (over the frame, or on the disoccluded
    pixels) below TAAU, FSR2 or bicubic; SSIM or IF-SSIM below TAAU by more than SSIM_SLACK."""
    d, out = per[default], []
    for key in psnr_keys:
        what = "PSNR" if key == "psnr" else "disoccluded PSNR"
        out += [f"{seq} {what} {d[key]:.2f} < {base} {per[base][key]:.2f}" for base in BASELINES
                if d.get(key) is not None and per[base].get(key) is not None and d[key] < per[base][key]]
    out += [f"{seq} {name} {d[key]:.4f} < taau {per['taau'][key]:.4f}" for key, name, _ in METRICS[1:]
            if d[key] is not None and per["taau"][key] is not None and d[key] < per["taau"][key] - SSIM_SLACK]
    return out


def entries(doc: dict):
    for config in SETS:
        for reference in REFERENCES:
            if reference in doc["sets"].get(config, {}):
                yield config, reference, doc["sets"][config][reference]


def write_doc(doc: dict) -> None:
    methods = [*doc["labels"], *BASELINES]
    lines = ["# Results: the engine judge", "", LEAD, "",
             "Generated by `scripts/engine_results.py` from `benchmarks/results/engine_results.json`; do not edit by hand.", "",
             f"What a studio sees when it tries the shipped models on its own frames, before it does: the held-out sets "
             f"`test_x2` and `unseen_x2` (docs/results.md) rewritten {VARIANTS[VARIANT][2]} ("
             "`mnss-kit data variant --apply engine`, docs/dataset.md), scored against the renderer's 16-sample box and "
             "against a native-resolution TAA frame, which is softer and is what an engine calls its ground truth.  "
             f"Every method sees the first {doc['frames']} frames of each sequence.  `fsr2` is the toolkit's FSR2-class "
             "upscaler (`mnss_kit/ops/fsr2.py`).", "", "## Where the default falls below", "", *below_lines(doc), ""]
    for config, reference, entry in entries(doc):
        lines += [f"## `{config}`, engine inputs, against the {REFERENCES[reference]}", "",
                  "| method | " + " | ".join(name for _, name, _ in METRICS) + " | frames below TAAU |",
                  "|---|" + "---:|" * (len(METRICS) + 1)]
        for m in methods:
            s = entry["methods"].get(m)
            if s is None:
                continue
            below, total = entry["frames_below_taau"][m]
            lines.append(f"| {m} | " + " | ".join(_cell(s[k], spec) for k, _, spec in METRICS)
                         + f" | {'' if m == 'taau' else f'{below} / {total}'} |")
        shown = [m for m in methods if m in entry["methods"]]
        lines += ["", "PSNR per sequence:", "", "| sequence | " + " | ".join(shown) + " |", "|---|" + "---:|" * len(shown)]
        lines += [f"| {seq} | " + " | ".join(_cell(per[m]["psnr"], "{:.2f}") for m in shown) + " |"
                  for seq, per in entry["sequences"].items()]
        lines.append("")
    if "stress" in doc:
        lines += stress_section(doc, methods)
    lines.append(f"Crops of every set and reference (the centre and the default's worst region): `{CROPS.relative_to(REPO)}/` "
                 "after a run (generated, not committed).")
    atomic_write_text(DOC, "\n".join(lines) + "\n")
    print(f"wrote {DOC.relative_to(REPO)}")


def stress_section(doc: dict, methods: list[str]) -> list[str]:
    """The two failure kinds' scenarios: PSNR over the frame and on the pixels disoccluded each frame."""
    entry = doc["stress"]
    shown = [m for m in methods if m in entry["methods"]]
    lines = ["## Stress: a figure crossing a textured wall, a strafe past alpha-tested foliage with a cut", "",
             "The scenarios of `mnss-kit stress` (`mnss_kit/configs/data/stress.yaml`) as it renders them: the toolkit's "
             "own inputs (grid jitter, float colour, exact motion) against the 16-sample box, every frame.  Each cell: PSNR "
             "over the frame / PSNR on the pixels disoccluded that frame.", "",
             "| scenario | " + " | ".join(shown) + " |", "|---|" + "---:|" * len(shown)]
    lines += [f"| {seq} | " + " | ".join(f"{_cell(per[m]['psnr'], '{:.2f}')} / {_cell(per[m].get('disocclusion_psnr'), '{:.2f}')}"
                                         for m in shown) + " |" for seq, per in entry["sequences"].items()]
    return lines + [""]


def _cell(value, spec: str) -> str:
    return "-" if value is None else spec.format(value)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=[DEFAULT_MODEL, "ntaau_x2", "ntaau_x2_fast", "mnss_x2"],
                        help="checkpoints or shipped names; the first is the default judged in the summary")
    parser.add_argument("--sets", nargs="+", choices=[*SETS, "stress"], default=[*SETS, "stress"],
                        help="the held-out sets and the stress scenarios (processes running different parts share the results)")
    parser.add_argument("--doc-only", action="store_true")
    args = parser.parse_args()
    if args.doc_only and not RESULTS.is_file():
        print(f"error: no results in {RESULTS.relative_to(REPO)} yet; run without --doc-only first", file=sys.stderr)
        return 2
    doc = read_json(RESULTS) if args.doc_only else run(args.models, args.sets)
    write_doc(doc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
