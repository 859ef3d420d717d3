#!/usr/bin/env python
"""The FSR2-class baseline beside TAAU and bicubic on the unseen set and the foliage set, in every
input variant of ``eval/variant_sets.py``: the tables of docs/fsr2.md ("Results"), rewritten
between its generated markers.

    python scripts/fsr2_results.py               # renders what is missing, evaluates, writes the tables
    python scripts/fsr2_results.py --doc-only    # rewrite the tables from benchmarks/results/fsr2_results.json

Each set is rendered with RENDER_FRAMES frames per sequence (the renders ``scripts/heldout_results.py``
keeps in the same work directory are reused) and the first FRAMES of each are evaluated.  Resumable:
finished set x variant entries are kept.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "scripts"))

from doc_blocks import replace_block  # noqa: E402
from mnss_kit.eval.variant_sets import VARIANTS, variant_set  # noqa: E402
from mnss_kit.fileio import atomic_write_json, atomic_write_text, read_json  # noqa: E402

RESULTS = REPO / "benchmarks" / "results" / "fsr2_results.json"
WORK = REPO / "benchmarks" / "results" / "work" / "variants"
DOC = REPO / "docs" / "fsr2.md"
BLOCK = "fsr2-results"
FRAMES = 16  # evaluated per sequence
RENDER_FRAMES = 24  # rendered per sequence, as scripts/heldout_results.py renders the same sets
METHODS = ("bicubic", "taau", "fsr2")
# set -> (its heading, the table's sequences: a name prefix, or "" for all)
TABLES = {
    "unseen_x2": [("unseen_x2 ({n} sequences: factory, rooms, garden)", ""),
                  ("garden sequences of unseen_x2 (alpha-tested grass, bushes, fence)", "garden")],
    "foliage_x2": [("foliage set (town and arena tree cards)", "")],
}


def evaluate_variant(config: str, variant: str) -> dict:
    """``{"methods": {method: PSNR}, "sequences": {sequence: {method: PSNR}}}`` of one set in one variant."""
    from mnss_kit.eval.baselines import baseline_methods
    from mnss_kit.eval.loop import evaluate

    data = variant_set(variant, config, WORK, RENDER_FRAMES, progress=True)
    result = evaluate(baseline_methods(2, METHODS), data, scale=2, max_frames=FRAMES, progress=True)
    return {"methods": {m: result["methods"][m]["psnr"] for m in METHODS},
            "sequences": {seq: {m: entry["methods"][m]["psnr"] for m in METHODS} for seq, entry in result["sequences"].items()}}


def read_results() -> dict:
    """The results so far (empty when written for other frames or other baseline settings)."""
    from mnss_kit.eval.baselines import baseline_settings

    doc = read_json(RESULTS) if RESULTS.is_file() else {}
    fresh = {"frames": FRAMES, "baselines": baseline_settings(), "sets": {}}
    return doc if all(doc.get(k) == fresh[k] for k in ("frames", "baselines")) else fresh


def run() -> dict:
    doc = read_results()
    for config in TABLES:
        for variant in VARIANTS:
            if variant not in doc["sets"].get(config, {}):
                print(f"{config} / {variant}", flush=True)
                doc["sets"].setdefault(config, {})[variant] = evaluate_variant(config, variant)
                atomic_write_json(RESULTS, doc)
    return doc


def sequences_named(entry: dict, prefix: str) -> dict:
    """``{sequence: {method: PSNR}}`` of one set x variant entry, the sequences named ``prefix...``."""
    return {s: per for s, per in entry["sequences"].items() if s.startswith(prefix)}


def mean_psnr(entry: dict, prefix: str) -> dict:
    """``{method: mean PSNR}`` over the sequences named ``prefix...``."""
    seqs = sequences_named(entry, prefix)
    return {m: sum(per[m] for per in seqs.values()) / len(seqs) for m in METHODS}


def table(entries: dict, prefix: str) -> list[str]:
    """Mean PSNR per variant over the sequences named ``prefix...``, and where fsr2 falls below taau."""
    lines = ["| variant | bicubic | taau | fsr2 | fsr2 - taau | sequences where fsr2 < taau |", "|---|---|---|---|---|---|"]
    for variant, entry in entries.items():
        mean = mean_psnr(entry, prefix)
        below = [f"{s} ({per['fsr2'] - per['taau']:+.2f})" for s, per in sequences_named(entry, prefix).items()
                 if per["fsr2"] < per["taau"]]
        lines.append(f"| {variant} | {mean['bicubic']:.2f} | {mean['taau']:.2f} | {mean['fsr2']:.2f} | "
                     f"{mean['fsr2'] - mean['taau']:+.2f} | {', '.join(below) or 'none'} |")
    return lines


def below_taau(doc: dict) -> str:
    """One sentence: the tables whose mean fsr2 is below taau, in which variants."""
    misses = []
    for config, tables in TABLES.items():
        for heading, prefix in tables:
            for variant, entry in doc["sets"].get(config, {}).items():
                mean = mean_psnr(entry, prefix)
                gap = mean["fsr2"] - mean["taau"]
                if gap < 0:
                    misses.append(f"{heading.split(' (')[0].format(n='')} {variant} ({gap:+.2f} dB)")
    if not misses:
        return "`fsr2` is at or above `taau` on mean PSNR in every variant of every table."
    return f"`fsr2` is at or above `taau` on mean PSNR in every variant except: {'; '.join(misses)}."


def write_doc(doc: dict) -> None:
    lines = []
    for config, tables in TABLES.items():
        entries = {v: doc["sets"][config][v] for v in VARIANTS if v in doc["sets"].get(config, {})}
        if not entries:
            lines += [f"{config}: not run yet.", ""]
            continue
        count = len(next(iter(entries.values()))["sequences"])
        for heading, prefix in tables:
            lines += [heading.format(n=count) + ":", "", *table(entries, prefix), ""]
    lines.append(below_taau(doc))
    atomic_write_text(DOC, replace_block(DOC.read_text(), BLOCK, "\n".join(lines), DOC))
    print(f"wrote {DOC.relative_to(REPO)}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--doc-only", action="store_true", help="only rewrite the tables from the results file")
    args = parser.parse_args()
    doc = read_results() if args.doc_only else run()
    write_doc(doc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
