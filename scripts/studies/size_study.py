#!/usr/bin/env python
"""``mnss-kit size`` on two built-in scenes each, for two ladders, and their study pages from the results.

Each scene is judged on a held-out sequence of its own that no rung trains on, with the same targets
on both scenes of a study:

- ``mnss``: the mnss ladder on the flat top-down arena and the dense foliage flight, trained on each
  scene's two sequences of ``train_x2``, judged on its ``test_x2`` sequence (docs/studies/size.md);
- ``ntaau_lr``: the ntaau_lr ladder, with ``CONFIG+detail`` rungs (the detail branch of ``finetune
  --detail`` fitted on the scene), on the furnished rooms and the open plaza of ``train_engine_x2``
  (no jitter), each scene's last sequence held out, two seeds per rung
  (docs/studies/size_ntaau_lr.md).

    python scripts/studies/size_study.py --data data                   # the mnss study (renders what is missing)
    python scripts/studies/size_study.py --data data --study ntaau_lr
    python scripts/studies/size_study.py --study ntaau_lr --doc-only   # rewrite the page from its size.json files

Each scene's run lives in ``benchmarks/results/<results>/<scene>/`` and continues where it stopped.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from mnss_kit.fileio import atomic_write_text, read_json  # noqa: E402


@dataclass(frozen=True)
class Study:
    page: str  # under docs/studies/
    results: str  # under benchmarks/results/
    renders: tuple[str, ...]  # render configs the scenes come from
    scenes: dict  # scene -> (training sequences, held-out sequences or None: the last of the training ones)
    ladder: tuple[str, ...]
    targets: tuple[str, ...]
    steps: int
    options: tuple[str, ...]  # further mnss-kit size arguments
    lead: str  # the page's opening line: what the reader can do with it
    about: str  # the ladder and the scenes, after the lead


STUDIES = {
    "mnss": Study(
        page="size.md", results="size", renders=("train_x2", "test_x2"),
        scenes={"arena": (["train_x2/arena_s1", "train_x2/arena_s2"], ["test_x2/arena_test"]),
                "flight": (["train_x2/flight_s5", "train_x2/flight_s6"], ["test_x2/flight_test"])},
        ladder=("mnss_x2_tiny", "mnss_x2_small", "mnss_x2"), targets=("within:0.3", "taau:0"), steps=1500, options=(),
        lead="This page records which model size `mnss-kit size` picks for two scenes of different complexity, and why.",
        about="on two built-in scenes of clearly different complexity."),
    "ntaau_lr": Study(
        page="size_ntaau_lr.md", results="size_ntaau_lr", renders=("train_engine_x2",),
        scenes={"rooms": ([f"train_engine_x2/rooms_e{i}" for i in (1, 7, 8, 10)], None),
                "plaza": ([f"train_engine_x2/plaza_e{i}" for i in (21, 22, 23)], None)},
        ladder=("ntaau_lr_x2_tiny", "ntaau_lr_x2_tiny+detail", "ntaau_lr_x2_small", "ntaau_lr_x2_small+detail",
                "ntaau_lr_x2", "ntaau_lr_x2+detail", "ntaau_lr_x2_large"),
        targets=("within:0.25", "taau:0"), steps=2000,
        options=("--held-out", "1", "--minutes", "28", "--max-frames", "24", "--set", "train.threads=1", "--seeds", "2"),
        lead="This page records which rung of the ntaau_lr ladder `mnss-kit size` picks for two scenes, and why: "
             "where the scene needs the detail branch a steering net alone cannot give.",
        about="with three `CONFIG+detail` rungs (CONFIG's trained steering plus the detail branch of "
              "`mnss-kit finetune --detail`, fitted on the scene's training sequences), each rung trained with two seeds "
              "and judged by their mean, on the furnished rooms and the open plaza of `train_engine_x2` (no jitter), "
              "each scene's last sequence held out."),
}


def size_command(study: Study, scene: str, data: Path) -> list[str]:
    train, test = study.scenes[scene]
    return [sys.executable, "-m", "mnss_kit", "size", "--data", *[str(data / s) for s in train],
            *(["--test", *[str(data / t) for t in test]] if test else []), "--ladder", *study.ladder,
            "--steps", str(study.steps), *[arg for t in study.targets for arg in ("--target", t)], *study.options,
            "--out", str(REPO / "benchmarks" / "results" / study.results / scene), "--no-progress"]


def ensure_data(study: Study, data: Path) -> None:
    for name in study.renders:
        if not (data / name).is_dir():
            subprocess.run([sys.executable, "-m", "mnss_kit", "render", name, "--out", str(data / name)], check=True)


def write_doc(study: Study) -> None:
    from mnss_kit.size.charts import markdown, write_chart

    results, charts = REPO / "benchmarks" / "results" / study.results, REPO / "docs" / "studies" / study.results
    largest = study.ladder[-1]
    lines = ["# Sizing a model to its scene", "", study.lead, "",
             f"Generated by `scripts/studies/size_study.py` from `benchmarks/results/{study.results}/*/size.json`; "
             "do not edit by hand.", "",
             "`mnss-kit size` trains a ladder of model configs for the same number of steps on a scene's own "
             "sequences, evaluates each on held-out sequences of that scene, and chooses the smallest whose "
             f"quality meets the targets. Here the targets are {_targets_text(study.targets, largest)}, the ladder is "
             f"{', '.join(f'`{n}`' for n in study.ladder)}, {study.steps} steps per rung, {study.about}", ""]
    docs = {}
    for scene in study.scenes:
        path = results / scene / "size.json"
        if not path.is_file():
            lines += [f"## {scene}", "", f"Not run yet: `{scene}` has no `size.json`.", ""]
            continue
        doc = read_json(path)
        docs[scene] = doc
        train, test = [Path(p).name for p in doc["settings"]["train_sequences"]], [Path(p).name for p in doc["settings"]["test_sequences"]]
        chart = write_chart(doc, charts / f"{scene}.png", title=f"{scene}: ladder on {', '.join(test)} (held out)")
        lines += [f"## {scene}", "", f"Trained on {', '.join(train)}; judged on {', '.join(test)}.", "",
                  "Reproduce: `" + " ".join(_portable(size_command(study, scene, Path("data")))) + "`", "",
                  markdown(doc), f"![{scene} ladder]({study.results}/{chart.name})", ""]
    if len(docs) == len(study.scenes):
        lines += ["## What the ladder says", "", _verdict(study, docs), "", *_sweep(study, docs), ""]
    page = REPO / "docs" / "studies" / study.page
    atomic_write_text(page, "\n".join(lines))
    print(f"wrote {page.relative_to(REPO)}")


def _targets_text(targets, largest: str) -> str:
    words = {"within": "PSNR at most {} dB below the largest rung, `" + largest + "`",
             "taau": "PSNR at least {} dB above TAAU's on the same frames"}
    return " and ".join(f"`{t}` ({words[t.split(':')[0]].format(t.split(':')[1])})" for t in targets)


def _verdict(study: Study, docs: dict[str, dict]) -> str:
    """What the choices say, from the numbers: each scene's choice, or its best rung against TAAU."""
    parts = []
    for scene, doc in docs.items():
        choice = (doc.get("choice") or {}).get("config")
        rows = sorted(doc["rows"].values(), key=lambda r: r["macs_per_pixel"])
        taau = doc["baselines"]["taau"]["psnr"]
        if choice:
            parts.append(f"{scene}: `{choice}` ({doc['rows'][choice]['psnr'] - taau:+.2f} dB against TAAU)")
        else:
            best = max(rows, key=lambda r: r["psnr"])
            parts.append(f"{scene}: no rung of this ladder (best `{best['config']}` at {best['psnr'] - taau:+.2f} dB against TAAU)")
    gaps = {scene: max(r["psnr"] for r in doc["rows"].values()) - min(r["psnr"] for r in doc["rows"].values())
            for scene, doc in docs.items()}
    spread = "; ".join(f"{scene} {gap:.2f} dB" for scene, gap in gaps.items())
    choices = {(doc.get("choice") or {}).get("config") for doc in docs.values()}
    verdict = ("The scenes chose differently." if len(choices) > 1 else "Both scenes chose the same size at these targets.")
    from mnss_kit.size.select import choose, parse_target

    first = study.targets[0]
    relative = {scene: choose(list(doc["rows"].values()), [parse_target(first)])[0]["config"] for scene, doc in docs.items()}
    alone = "; ".join(f"{scene} `{name}`" for scene, name in relative.items())
    return (f"Chosen per scene: {'; '.join(parts)}. {verdict} Spread between the weakest and the best rung: {spread}. "
            f"`{first}` alone would choose: {alone}. Where no rung meets `taau:0`, the scene needs more model or "
            f"more training than this ladder gives at {study.steps} steps.")


def _sweep(study: Study, docs: dict[str, dict]) -> list[str]:
    """The choice per scene under other targets, from the same rows (nothing retrained)."""
    from mnss_kit.size.select import choose, parse_target

    seeds = max(len(r.get("seeds") or [r]) for doc in docs.values() for r in doc["rows"].values())
    evidence = ("Each rung was trained once, with one seed: how far another seed would move a rung is not measured, "
                "so a gap of a tenth of a decibel between rungs is weak evidence." if seeds == 1 else
                f"Each rung was trained with {seeds} seeds and is judged by their mean; the ladders above give each "
                "seed's PSNR.")
    within = [t for t in study.targets if t.startswith("within:")][0]
    sweep = [[within], *([f"within:{v}"] for v in ("0.2", "0.1", "0.05") if f"within:{v}" != within),
             ["taau:0"], ["taau:0.25"], list(study.targets), [within, "taau:0.25"]]
    columns = {scene: [list(doc["rows"].values())] for scene, doc in docs.items()}
    if seeds > 1:  # each seed's runs alone as well: does the choice hold seed by seed?
        evidence += " The columns per seed choose from that seed's runs alone."
        for scene, doc in docs.items():
            columns[scene] += [[{**r, **r["seeds"][k]} for r in doc["rows"].values()] for k in range(seeds)]
    heads = [scene if k == 0 else f"{scene}, seed {rows[0]['seed']}" for scene, sets in columns.items()
             for k, rows in enumerate(sets)]
    lines = ["### The same rows under other targets", "",
             "`mnss-kit size` applies new targets to the rungs it has already trained; each row below is such a rerun "
             f"(no training). {evidence}", "",
             "| targets | " + " | ".join(heads) + " |", "|---|" + "---|" * len(heads)]
    for targets in sweep:
        cells = []
        for scene, sets in columns.items():
            for rows in sets:
                chosen, _ = choose(rows, [parse_target(t) for t in targets], baselines=docs[scene]["baselines"])
                cells.append(f"`{chosen['config']}`" if chosen else "none")
        lines.append(f"| {' '.join(f'`{t}`' for t in targets)} | " + " | ".join(cells) + " |")
    return lines


def _portable(argv: list[str]) -> list[str]:
    out = ["mnss-kit" if a == sys.executable else a for a in argv]
    out = [a for a in out if a != "-m" and a != "mnss_kit"]
    return [Path(a).relative_to(REPO).as_posix() if a.startswith(str(REPO)) else a for a in out]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", choices=list(STUDIES), default="mnss", help="which ladder (default: %(default)s)")
    parser.add_argument("--data", type=Path, default=Path("data"), help="holds the study's renders (default: %(default)s)")
    parser.add_argument("--scenes", nargs="+", help="run only these scenes of the study")
    parser.add_argument("--doc-only", action="store_true", help="only rewrite the study's page from its size.json files")
    args = parser.parse_args()
    study = STUDIES[args.study]
    unknown = sorted(set(args.scenes or []) - set(study.scenes))
    if unknown:
        parser.error(f"--scenes: the {args.study} study has no scene '{unknown[0]}' ({', '.join(study.scenes)})")
    if not args.doc_only:
        ensure_data(study, args.data)
        for scene in args.scenes or study.scenes:
            result = subprocess.run(size_command(study, scene, args.data))
            if result.returncode not in (0, 1):  # 1: no rung met the target, still a result to report
                return result.returncode
    write_doc(study)
    return 0


if __name__ == "__main__":
    sys.exit(main())
