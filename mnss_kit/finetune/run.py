"""``finetune``: a model tuned on the first frames of a studio's capture, judged on the rest.

    OUT/split/tune/     the first (1 - hold_back) of each sequence's frames (hard links)
    OUT/split/judged/   warm-up frames, then the held-back ones
    OUT/run/            the training run (``last.pt`` while it runs, ``model.pt`` when done)
    OUT/detail/         with ``detail``: the run's model with a detail branch fitted (finetune.detail)
    OUT/heldback.json   the judgement: per method and sequence, held-back frames only
    OUT/heldback.md     its table;  OUT/crops/  side-by-side crops of the held-back frames

The recipe (:data:`RECIPE`) starts from the model's own training settings (window, burn-in, crop,
loss weights, augmentations) and changes what a short fine-tune needs changed; every step resumes:
a finished split or run is kept, an interrupted run continues from its ``last.pt``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from ..config import from_dict
from ..dataset import format as fmt
from ..dataset.check import require_clean
from ..errors import UserError
from ..fileio import atomic_write_json, atomic_write_text, portable_path
from .split import SequenceSplit, plan_split, write_split

log = logging.getLogger(__name__)

# What a short fine-tune changes in the model's own training settings, and why:
RECIPE = {
    "lr": 1.0e-4,  # a tenth of a base run's: the weights are close to where they should stay
    "lr_schedule": "constant",  # the budget, not the schedule, ends the run
    "gt_history_epochs": 0,  # ground-truth history teaches a net to trust history; a short run would learn only that
    "val_data": None,  # the held-back frames judge the run once, at its end
    "epochs": 100_000,  # steps are limited by the time budget
    "total_steps": None,  # not the start model's own run length, which would end the fine-tune first
    "steps_per_epoch": 100,
    "checkpoint_every": 25,  # an interrupted run loses at most this many steps
    "val_every": 0,
}
DEFAULT_MINUTES = 15.0
# of the minutes with ``detail``: the branch's fit (recording included); the steering gets the rest.
# The wider branch takes longer to fit, and the steering's share adds little (docs/studies/ntaau_lr.md)
DETAIL_SHARE = 0.7
DEFAULT_HOLD_BACK = 0.4
DEFAULT_WARMUP = 4
JUDGED_METRICS = ("psnr", "ssim", "if_ssim", "temporal_error")
JUDGED_BASELINES = ("taau", "fsr2", "bicubic")


@dataclass
class FinetuneResult:
    table: str
    summary: dict
    out: Path


def finetune(capture: Path, out: Path, model: str, minutes: float = DEFAULT_MINUTES, hold_back: float = DEFAULT_HOLD_BACK,
             warmup: int = DEFAULT_WARMUP, sequences: list[str] | None = None, progress: bool = True,
             detail: bool = False, threads: int = 0, detail_width: int | None = None) -> FinetuneResult:
    """Fine-tune ``model`` on ``capture`` and judge it on the held-back frames (see the module doc);
    ``detail``: the steering for part of the minutes, then a detail branch fitted (ntaau_lr only),
    of ``detail_width`` when given (else ``finetune.detail.BRANCH``'s);
    ``threads``: torch threads for both (``train.threads``: 0 is a share of the idle cores)."""
    from .detail import branch_settings, check_detail, fit_detail

    if not 0.0 < hold_back < 1.0:
        raise UserError(f"--hold-back is the share of frames judged, in (0, 1); got {hold_back}")
    if minutes <= 0:
        raise UserError(f"--minutes must be positive, got {minutes}")
    if threads < 0:
        raise UserError(f"--threads must be >= 0 (0: a share of the idle cores), got {threads}")
    if detail_width is not None and (not detail or detail_width < 1):
        raise UserError(f"--detail-width takes a positive width and --detail; got {detail_width}"
                        + ("" if detail else " without --detail"))
    seqs = _checked_sequences(capture, sequences)
    smallest = min(min(fmt.read_meta(s).lr_size) for s in seqs)
    steer_minutes = minutes * (1.0 - DETAIL_SHARE) if detail else minutes
    experiment, record = _experiment(model, out / "split" / "tune", steer_minutes, smallest, threads)
    if detail:
        check_detail(record, model)
    train_cfg = experiment.train
    splits = [plan_split(s, fmt.read_meta(s), hold_back, warmup, train_cfg.burn_in + train_cfg.window) for s in seqs]
    _check_scale(seqs, record, model)
    write_split(seqs, splits, out / "split" / "tune", out / "split" / "judged")
    tuned = _train(experiment, out / "run", model, progress)
    if detail:
        tuned = fit_detail(tuned, out / "split" / "tune", out / "detail", minutes * DETAIL_SHARE, warmup, progress,
                           experiment.train.threads, detail_width)
    summary = _judge(model, tuned, out, splits, progress)
    summary["settings"] = {"capture": portable_path(capture), "model": model, "minutes": minutes, "hold_back": hold_back,
                           "warmup": warmup, "recipe": RECIPE, "threads": threads, "detail": detail,
                           "detail_share": DETAIL_SHARE if detail else None,
                           "detail_width": branch_settings(detail_width)["detail_width"] if detail else None,
                           "sequences": {s.name: {"frames": s.frames, "tuned": len(s.tune), "held_back": len(s.held_back)}
                                         for s in splits}}
    atomic_write_json(out / "heldback.json", summary)
    table = format_judgement(summary)
    atomic_write_text(out / "heldback.md", table + "\n")
    return FinetuneResult(table, summary, out)


def _checked_sequences(capture: Path, names: list[str] | None) -> list[Path]:
    """The capture's sequences (or those named), after ``data check`` finds no error in them."""
    seqs = fmt.find_sequences(capture)
    if names:
        by_name = {s.name: s for s in seqs}
        missing = [n for n in names if n not in by_name]
        if missing:
            raise UserError(f"{capture}: no sequence '{missing[0]}' (it has {', '.join(by_name)})")
        seqs = [by_name[n] for n in names]
    for seq in seqs:
        require_clean(seq)
    return seqs


def _experiment(model: str, tune_dir: Path, minutes: float, smallest_side: int, threads: int = 0):
    """The fine-tune's experiment: the checkpoint's own model config and training settings with RECIPE,
    its crops no larger than the capture's smallest LR side, on ``threads`` torch threads."""
    from ..model import checkpoint
    from ..model.config import model_config_from_dict
    from ..train.config import ExperimentConfig, TrainConfig

    record, _ = checkpoint.read_record(model)
    trained = {k: v for k, v in (record.get("train") or {}).items() if k in TrainConfig.__dataclass_fields__}
    settings = {**trained, **RECIPE, "train_data": [str(tune_dir)], "time_budget_min": minutes, "init": None,
                "threads": threads}
    settings["crop"] = min(settings.get("crop", smallest_side), smallest_side)
    train_cfg = from_dict(TrainConfig, settings, source=f"{model} record")
    config = model_config_from_dict(record.get("config"), source=f"{model} record")
    return ExperimentConfig(model=config, train=train_cfg), record


def _check_scale(seqs: list[Path], record: dict, model: str) -> None:
    for seq in seqs:
        scale = fmt.read_meta(seq).scale
        if scale != record.get("scale"):
            raise UserError(f"{seq} is x{scale} but {model} is x{record.get('scale')}")


def _train(experiment, run_dir: Path, model: str, progress: bool) -> Path:
    """The run's ``model.pt``: kept when the run finished, resumed from ``last.pt`` when it was cut."""
    from ..train.run import train
    from ..train.state import FINAL, LAST

    if (run_dir / FINAL).is_file():
        log.info("fine-tune already finished: %s", run_dir / FINAL)
        return run_dir / FINAL
    resume = (run_dir / LAST).is_file()
    return train(experiment, run_dir, resume=resume, progress=progress, init=None if resume else model)


def _judge(model: str, tuned: Path, out: Path, splits: list[SequenceSplit], progress: bool) -> dict:
    """Every method on the judged frames; means over the held-back frames only."""
    from ..eval.baselines import baseline_methods
    from ..eval.methods import model_method
    from ..eval.loop import evaluate
    from ..eval.summary import method_stats
    from ..model import checkpoint

    shipped, record = checkpoint.load(model)
    fine, _ = checkpoint.load(tuned)
    methods = {"finetuned": model_method(fine), "before": model_method(shipped),
               **baseline_methods(record["scale"], JUDGED_BASELINES)}
    result = evaluate(methods, out / "split" / "judged", progress=progress, crops_dir=out / "crops")
    warmups = {s.name: s.warmup for s in splits}
    held = [r for r in result["per_frame"] if r["frame"] >= warmups[r["sequence"]]]
    summary = {"frames": len({(r["sequence"], r["frame"]) for r in held}), "methods": {}, "sequences": {}}
    for name in methods:
        summary["methods"][name] = _stats(method_stats([r for r in held if r["method"] == name]))
    for seq in warmups:
        summary["sequences"][seq] = {name: _stats(method_stats([r for r in held if r["method"] == name and r["sequence"] == seq]))
                                     for name in methods}
    summary["per_frame"] = held
    return summary


def _stats(stats: dict) -> dict:
    return {k: stats.get(k) for k in ("frames", *JUDGED_METRICS)}


def format_judgement(summary: dict) -> str:
    """A Markdown table: per method, the held-back means and the PSNR margin over the model before tuning."""
    before = summary["methods"]["before"]["psnr"]
    lines = ["| method | PSNR (dB) | vs before | SSIM | IF-SSIM | warp error |", "|---|---:|---:|---:|---:|---:|"]
    for name, s in summary["methods"].items():
        cells = [f"{s['psnr']:.2f}", f"{s['psnr'] - before:+.2f}", f"{s['ssim']:.4f}",
                 *("-" if s.get(k) is None else f"{s[k]:.{d}f}" for k, d in (("if_ssim", 4), ("temporal_error", 5)))]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines.append(f"\n{summary['frames']} held-back frame(s); `before` is the model the fine-tune started from; "
                 "the warp error is the mean change from the frame before, warped (lower is steadier).")
    return "\n".join(lines)
