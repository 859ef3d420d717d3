#!/usr/bin/env python
"""Models against the toolkit's TAAU and bicubic on data they never saw, in the input variants
engines send: the held-out set ``test_x2`` and the unseen set ``unseen_x2`` (scene families no
training config renders, one of them built from meshes and textures no training scene uses),
each with the MNSS jitter, without jitter at 8-bit colour and depth, and with Halton jitter.
Writes ``bench/results/heldout_results.json`` and ``docs/results.md`` (with one crop per set in
``docs/results/``).

    python scripts/heldout_results.py                     # the shipped ntaau_x2, ntaau_x2_fast and mnss_x2
    python scripts/heldout_results.py --models runs/ntaau_x2/model.pt runs/ntaau_x2_fast/model.pt mnss_x2
    python scripts/heldout_results.py --sets unseen_x2    # one set; another process may run the other
    python scripts/heldout_results.py --doc-only

The first model is the candidate default the targets are checked for; the second the fast one.
Its int8 is its deployment bundle (exported with calibration on the training data) through the
emulator (numpy GPU passes, the NPU in LiteRT's reference numerics), measured on the unseen set
with the MNSS jitter.  Resumable: finished set x variant entries are kept (for the
same models and frame count).  Every sequence is cut to its first FRAMES frames.
"""

from __future__ import annotations

import argparse
import contextlib
import fcntl
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mnss_kit.bench.run import model_label  # noqa: E402
from mnss_kit.eval.variant_sets import VARIANTS, variant_set  # noqa: E402
from mnss_kit.fileio import atomic_write_bytes, atomic_write_json, atomic_write_text, read_json  # noqa: E402
from mnss_kit.zoo import DEFAULT_MODEL  # noqa: E402

RESULTS = REPO / "bench" / "results" / "heldout_results.json"
WORK = REPO / "bench" / "results" / "work" / "variants"
CROPS = REPO / "bench" / "results" / "heldout_crops"
BUNDLES = REPO / "bench" / "results" / "work" / "heldout_bundles"
DOC = REPO / "docs" / "results.md"
DOC_CROPS = REPO / "docs" / "results"  # the crops the doc shows, <set>_crop.png (one per set, about 150 KB each)
FRAMES = 24  # evaluated per sequence
RENDER_FRAMES = 48  # rendered per variant sequence (the sets input_variants.py renders too)
SETS = {"test_x2": "data/test_x2", "unseen_x2": None}  # render config -> the MNSS-jitter set already rendered (None: render)
SHOWN = ("mnss", "no_jitter_ldr8_depth8", "halton")
BASELINES = ("taau", "bicubic")
CALIBRATION = "data/train_x2"  # quantization calibrates on training frames, never on held-out ones
# targets for the default model (the first) and the fast one (the second)
TAAU_MARGIN_DB, BICUBIC_MARGIN_DB = 1.0, 4.0
INT8_PSNR_DB, INT8_IF_SSIM = 0.1, 0.001


def evaluate_entry(models: list[str], data: Path, crops: Path | None, int8: bool) -> dict:
    from mnss_kit.bench.emulated import bundle_method
    from mnss_kit.bench.run import export_at_size, quality_table
    from mnss_kit.eval.baselines import baseline_methods
    from mnss_kit.eval.methods import model_method
    from mnss_kit.eval.run import evaluate
    from mnss_kit.model.checkpoint import load

    methods = {}
    for name in models:
        model, _ = load(name)
        model.eval()
        methods[model_label(name)] = model_method(model)
        if int8 and name == models[0]:
            bundle = export_at_size(name, data, REPO / CALIBRATION, BUNDLES / model_label(name))
            methods[f"{model_label(name)} int8"] = bundle_method(bundle)
    methods.update(baseline_methods(2, BASELINES))
    result = evaluate(methods, data, scale=2, max_frames=FRAMES, crops_dir=crops, progress=False)
    return quality_table(result, methods)


def read_results(models: list[str]) -> dict:
    """The results so far for ``models`` (empty when the file holds other models or frames)."""
    doc = read_json(RESULTS) if RESULTS.is_file() else {}
    if doc.get("models") != models or doc.get("frames") != FRAMES:
        doc = {"models": models, "labels": [model_label(m) for m in models], "frames": FRAMES, "sets": {}}
    return doc


@contextlib.contextmanager
def results_lock():
    """Held while the results file is read, changed and written: processes running other sets add to it."""
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    with open(RESULTS.with_suffix(".lock"), "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield


def run(models: list[str], sets: list[str]) -> dict:
    with results_lock():
        doc = read_results(models)
        atomic_write_json(RESULTS, doc)
    for config in sets:
        base = SETS[config]
        for variant in SHOWN:
            if variant in doc["sets"].get(config, {}):
                continue
            print(f"{config} / {variant}", flush=True)
            data = variant_set(variant, config, WORK, RENDER_FRAMES, base=REPO / base if base else None)
            crops = CROPS / config if variant == "mnss" else None
            entry = evaluate_entry(models, data, crops, int8=config == "unseen_x2" and variant == "mnss")
            with results_lock():
                doc = read_results(models)
                doc["sets"].setdefault(config, {})[variant] = entry
                atomic_write_json(RESULTS, doc)
    return doc


def in_order(doc: dict) -> list[tuple[str, dict]]:
    """The results' sets in the order of SETS, whichever process finished first."""
    return [(config, doc["sets"][config]) for config in SETS if config in doc["sets"]]


def checks(doc: dict) -> list[str]:
    """The targets, each as one line stating the measured numbers and whether it is met."""
    default, fast = doc["labels"][0], (doc["labels"][1] if len(doc["labels"]) > 1 else None)
    lines = []
    for config, entries in in_order(doc):
        for variant, entry in entries.items():
            m, t, b = (entry["methods"][k] for k in (default, "taau", "bicubic"))
            below = [f"{seq} ({metric} {per[default][metric]:.4g} < {per['taau'][metric]:.4g})"
                     for seq, per in entry["sequences"].items() for metric in ("psnr", "ssim", "if_ssim")
                     if per[default][metric] < per["taau"][metric]]
            margin = m["psnr"] - t["psnr"]
            lines.append(f"- `{config}` / {variant}: {default} {m['psnr']:.2f} dB, TAAU {t['psnr']:.2f} ({margin:+.2f}, target "
                         f"+{TAAU_MARGIN_DB:.1f}: {'met' if margin >= TAAU_MARGIN_DB else 'missed'}); below TAAU on "
                         f"{'; '.join(below) if below else 'no sequence and no metric'}")
            if variant == "mnss":
                gain = m["psnr"] - b["psnr"]
                lines.append(f"  - over bicubic {gain:+.2f} dB (target +{BICUBIC_MARGIN_DB:.1f}: {'met' if gain >= BICUBIC_MARGIN_DB else 'missed'})")
            if fast:
                f = entry["methods"][fast]
                lines.append(f"  - fast {fast} {f['psnr']:.2f} dB against TAAU {t['psnr']:.2f} "
                             f"({'beats it' if f['psnr'] > t['psnr'] else 'does not beat it'})")
            int8 = entry["methods"].get(f"{default} int8")
            if int8:
                dp, di = int8["psnr"] - m["psnr"], int8["if_ssim"] - m["if_ssim"]
                ok = dp >= -INT8_PSNR_DB and di >= -INT8_IF_SSIM
                lines.append(f"  - int8 {dp:+.3f} dB PSNR, {di:+.4f} IF-SSIM against fp32 (limits -{INT8_PSNR_DB} dB, "
                             f"-{INT8_IF_SSIM}: {'met' if ok else 'missed'}; the bundle through the emulator)")
    return lines


def shown_crops(doc: dict) -> dict[str, tuple[str, str]]:
    """Per set, the crop the doc shows, copied from CROPS into DOC_CROPS when a run left it: the
    default model's worst region, on the sequence where it is furthest below (or least above)
    TAAU with the MNSS jitter, in the last frame cropped."""
    default, shown = doc["labels"][0], {}
    for config, entries in in_order(doc):
        per = entries.get("mnss", {}).get("sequences", {})
        if not per:
            continue
        seq = min(per, key=lambda s: per[s][default]["psnr"] - per[s]["taau"]["psnr"])
        candidates = sorted((CROPS / config).glob(f"{seq}_*_worst.png"))
        target = DOC_CROPS / f"{config}_crop.png"
        if candidates:
            target.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(target, candidates[-1].read_bytes())
            shown[config] = (candidates[-1].stem, f"{seq}, frame {int(candidates[-1].stem.split('_')[-2])}")
        elif target.is_file():  # --doc-only without the run's crops: keep the committed picture
            shown[config] = (target.stem, f"{seq}")
    return shown


def write_doc(doc: dict) -> None:
    methods = [*doc["labels"], *(f"{doc['labels'][0]} int8",), *BASELINES]
    lines = [f"# Results: the default model {doc['labels'][0]} on held-out and unseen data, in the inputs engines send", "",
             "Generated by `scripts/heldout_results.py` from `bench/results/heldout_results.json`; do not edit by hand.", "",
             f"Every method sees the same frames: the first {doc['frames']} of each sequence.  `test_x2` is the held-out "
             "set (training scenes, other seeds and hand-written camera paths); `unseen_x2` holds two scene families no "
             "training config renders: the factory interior (`factory_u*`) and furnished rooms (`rooms_u*`) whose real "
             "meshes and photographic textures no training scene uses (docs/assets.md).  Variants: "
             + "; ".join(f"**{v}**: {VARIANTS[v][2]}" for v in SHOWN) + ".", "", "## Targets", "", *checks(doc), "", "## Means", ""]
    for config, entries in in_order(doc):
        for variant, entry in entries.items():
            shown = [m for m in methods if m in entry["methods"]]
            lines += [f"### `{config}` / {variant}", "", "| method | PSNR | SSIM | IF-SSIM | temporal error | phase offset |",
                      "|---|---:|---:|---:|---:|---:|"]
            lines += [f"| {m} | {q['psnr']:.2f} | {q['ssim']:.4f} | {q['if_ssim']:.4f} | {q['temporal_error']:.4f} | "
                      f"{q['phase_offset']:.2f} |" for m, q in ((m, entry["methods"][m]) for m in shown)]
            seq_methods = [m for m in shown if not m.endswith(" int8")]
            lines += ["", "Per sequence, PSNR / IF-SSIM:", "", "| sequence | " + " | ".join(seq_methods) + " |",
                      "|---|" + "---:|" * len(seq_methods)]
            lines += [f"| {seq} | " + " | ".join(f"{per[m]['psnr']:.2f} / {per[m]['if_ssim']:.4f}" for m in seq_methods) + " |"
                      for seq, per in entry["sequences"].items()]
            lines.append("")
    lines += ["Phase offset (`mnss_kit/metrics/pattern.py`): the largest gap between the mean signed error of one of the "
              "output's sub-pixel phases and the mean over all pixels, in 8-bit levels, averaged over frames: a fixed "
              "dot pattern shows here, noise does not.", "", "## Side by side", ""]
    for config, (name, note) in shown_crops(doc).items():
        lines += [f"`{config}`, {note}: reference, each method with its PSNR on the crop, and error maps.", "",
                  f"![{config} {name}]({DOC_CROPS.relative_to(DOC.parent).as_posix()}/{config}_crop.png)", ""]
    lines.append(f"Every crop of the MNSS-jitter runs (the centre and the default model's worst region of two frames per "
                 f"sequence): `{CROPS.relative_to(REPO)}/` after a run (generated, not committed).")
    atomic_write_text(DOC, "\n".join(lines) + "\n")
    print(f"wrote {DOC.relative_to(REPO)}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=[DEFAULT_MODEL, "ntaau_x2_fast", "mnss_x2"],
                        help="checkpoints or shipped names; the first is the candidate default, the second the fast one")
    parser.add_argument("--sets", nargs="+", choices=list(SETS), default=list(SETS),
                        help="run these sets only (processes running different sets share the results file)")
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
