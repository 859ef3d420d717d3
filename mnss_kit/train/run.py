"""The train stage's entry, the training loop: ``train(experiment, out_dir)`` -> ``out_dir/model.pt``.

One optimizer step per batch of recurrent windows.  Each window runs frame by
frame from an empty history; with ``bptt = K`` the history is detached every
K frames and each K-frame chunk is backpropagated on its own (gradients add
up; under DDP only the last chunk's backward all-reduces them).  Everything
that decides the result (initial weights, window order, crops) derives from
``seed`` and the step, so ``resume`` from ``last.pt`` reproduces an
uninterrupted run.
"""

from __future__ import annotations

import contextlib
import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path

import torch
from torch import nn

from ..config import to_dict
from ..errors import UserError
from ..fileio import remove_stale_leftovers
from ..model import checkpoint
from ..model.families import build_model, family_of
from . import distributed
from .config import ExperimentConfig, TrainConfig, changed_train_keys
from .data import ensure_data, open_windows, step_loader
from .init import initial_weights
from .recurrent import WindowChunk, burn_in, detach_state, validate
from .state import FINAL, LAST, load_last, save_final, save_last
from .summaries import Summaries

log = logging.getLogger(__name__)


@dataclass
class RunState:
    """What a run has done so far (restored from ``last.pt`` on resume)."""

    step: int = 0
    elapsed_s: float = 0.0  # training wall time over all sessions of the run
    recent_loss: float = math.nan  # mean total loss of the last logged steps
    val_psnr: float = math.nan
    stopped: str = "completed"  # completed | time_budget | interrupted
    init: dict | None = None  # identity of the checkpoint the run's weights started from (--init)

    def progress(self, cfg: TrainConfig) -> dict:
        return {"step": self.step, "epochs_done": self.step // cfg.steps_per_epoch, "elapsed_s": self.elapsed_s,
                "recent_loss": self.recent_loss, "val_psnr": self.val_psnr}


def train(experiment: ExperimentConfig, out_dir: str | Path, resume: bool = False, progress: bool = True,
          init: str | None = None) -> Path:
    """Train ``experiment`` into ``out_dir`` (``last.pt``, ``model.pt``, ``logs/``); returns model.pt's path.

    ``init``: a checkpoint (shipped name or path) whose weights the run starts from instead of a
    random initialisation (checked by ``init.initial_weights``).  Under ``torchrun`` every process calls
    this; rank 0 alone writes files.
    """
    if init and resume:
        raise UserError("--init starts a new run; --resume continues one from its last.pt (use one of them)")
    if init is None and not resume and experiment.train.init:
        init = _config_init(experiment.train.init)
    world = distributed.setup()
    try:
        return _train(experiment, Path(out_dir), resume, progress, world, init)
    finally:
        distributed.teardown(world)


def trained_parameters(model: nn.Module, prefixes: list[str] | None) -> list[nn.Parameter]:
    """The parameters ``train.trainable`` names (all when None); the others get no gradient."""
    if prefixes is None:
        return list(model.parameters())
    trained = []
    for name, param in model.named_parameters():
        param.requires_grad_(any(name.startswith(p) for p in prefixes))
        if param.requires_grad:
            trained.append(param)
    if not trained:
        names = sorted({n.split(".")[0] + "." for n, _ in model.named_parameters()})
        raise UserError(f"train.trainable {prefixes} names no parameter of the model (its parameters start with "
                        f"{', '.join(names)})")
    return trained


def _config_init(init: str) -> str:
    """The config's ``train.init``, checked to exist before any work: a fine-tune config names the
    run it continues, which the user may not have trained yet."""
    try:
        checkpoint.resolve(init)
    except UserError:
        raise UserError(f"the config starts from train.init '{init}', which does not exist: train that run first "
                        "(docs/training.md), or pass --init") from None
    return init


def _train(experiment: ExperimentConfig, out_dir: Path, resume: bool, progress: bool, world: distributed.World,
           init: str | None) -> Path:
    cfg = experiment.train
    threads = distributed.cpu_threads(world, cfg.threads)
    torch.set_num_threads(threads)
    _check_out_dir(out_dir, resume)
    weights, initial = initial_weights(experiment.model, init) if init else (None, None)  # before any data work
    trained_parameters(build_model(experiment.model), cfg.trainable)  # a prefix naming nothing: refused before it too
    if world.is_main:
        ensure_data(cfg, experiment.data, progress)
    frame_scale = takes_frame_scale(experiment.model)
    check_scales(experiment.model, data_scales(cfg.train_dirs()), frame_scale)  # before the cache is built
    windows, val_windows = _open_data(cfg, world, progress, family_of(experiment.model), frame_scale)

    torch.manual_seed(cfg.seed)  # identical initial weights on every rank
    model = build_model(experiment.model)
    if weights is not None:
        model.load_state_dict(weights)
    optimizer = torch.optim.Adam(trained_parameters(model, cfg.trainable), lr=cfg.lr, betas=cfg.betas, eps=cfg.eps)
    run = _resume(out_dir, model, optimizer, experiment) if resume else RunState(init=initial)
    record = _record(experiment, windows)
    record["init"] = run.init
    log.info("training %d steps of %d x %d windows (%d+%d frames, %d px crops), %d process(es) x %d thread(s)",
             cfg.steps, world.size, cfg.batch_size, cfg.burn_in, cfg.window, cfg.crop, world.size, threads)

    log_dir = Path(cfg.log_dir) if cfg.log_dir else out_dir / "logs"
    # only the run directory's own logs/ is cleared: a train.log_dir may hold other runs' events
    summaries = Summaries(log_dir if world.is_main else None, run.step, fresh=not resume and not cfg.log_dir)
    chunk = WindowChunk(model, family_of(experiment.model).loss(experiment.model, cfg))
    runner = nn.parallel.DistributedDataParallel(chunk) if world.distributed else chunk
    try:
        steps_per_s = _run_steps(cfg, run, model, optimizer, runner, windows, val_windows, summaries, out_dir, record, world, progress)
    finally:
        summaries.close()

    digests = distributed.gather_strings(world, distributed.weights_digest(model))
    if len(set(digests)) != 1:
        raise RuntimeError(f"data-parallel replicas diverged: weight digests {digests}")
    record["training"] = {
        "steps": run.step,
        "epochs": run.step / cfg.steps_per_epoch,
        "wall_time_s": run.elapsed_s,
        "final_loss": run.recent_loss,
        "val_psnr": run.val_psnr,
        "steps_per_second": steps_per_s,
        "stopped": run.stopped,
        "world_size": world.size,
        "threads_per_process": threads,
        "windows_per_step": cfg.batch_size * world.size,
        "weight_digests": digests,
    }
    final = out_dir / FINAL
    if world.is_main:
        save_last(out_dir / LAST, model, record, optimizer, run.progress(cfg))
        save_final(final, model, record)
        log.info("wrote %s (%d steps, %.1f min, %.2f steps/s, loss %.4f)", final, run.step, run.elapsed_s / 60, steps_per_s, run.recent_loss)
    distributed.barrier(world)
    return final


def _resume(out_dir: Path, model, optimizer, experiment: ExperimentConfig) -> RunState:
    record, saved = load_last(out_dir / LAST, model, optimizer)
    _check_resumable(record, experiment)
    log.info("resuming %s at step %d of %d", out_dir, saved["step"], experiment.train.steps)
    return RunState(step=saved["step"], elapsed_s=saved["elapsed_s"], recent_loss=saved["recent_loss"], val_psnr=saved["val_psnr"],
                    init=record.get("init"))


def _run_steps(cfg, run, model, optimizer, runner, windows, val_windows, summaries, out_dir, record, world, progress) -> float:
    """Train from ``run.step`` to the end, the time budget, or Ctrl-C; returns steps per second."""
    from tqdm import tqdm

    loader = step_loader(windows, cfg, world.rank, world.size, run.step)
    val_indices = _spread(len(val_windows), cfg.val_windows) if val_windows is not None else []
    bar = tqdm(total=cfg.steps, initial=run.step, unit="step", desc="train", disable=None if (progress and world.is_main) else True, dynamic_ncols=True)
    running = torch.zeros(len(_chunk(runner).loss.terms))
    logged_steps = 0
    start_time, start_step = time.perf_counter(), run.step
    prior_elapsed = run.elapsed_s
    try:
        for batch in loader:
            _set_lr(optimizer, cfg, run.step)
            running += _step(cfg, run.step, model, optimizer, runner, batch, world)
            run.step += 1
            logged_steps += 1
            run.elapsed_s = prior_elapsed + time.perf_counter() - start_time
            bar.update(1)
            if run.step % cfg.log_every == 0 or run.step == cfg.steps:
                _log_terms(run, running / logged_steps, optimizer, summaries, bar, world, runner)
                running.zero_()
                logged_steps = 0
            if world.is_main and val_indices and ((cfg.val_every and run.step % cfg.val_every == 0) or run.step == cfg.steps):
                _validate(cfg, run, model, val_windows, val_indices, summaries)
            if world.is_main and run.step % cfg.checkpoint_every == 0 and run.step < cfg.steps:
                save_last(out_dir / LAST, model, record, optimizer, run.progress(cfg))
            over_budget = cfg.time_budget_min is not None and run.elapsed_s >= cfg.time_budget_min * 60.0
            if distributed.any_rank(world, over_budget) and run.step < cfg.steps:
                run.stopped = "time_budget"
                log.warning("time budget of %.1f min reached at step %d of %d", cfg.time_budget_min, run.step, cfg.steps)
                break
    except KeyboardInterrupt:
        run.stopped = "interrupted"
        if world.is_main:
            save_last(out_dir / LAST, model, record, optimizer, run.progress(cfg))
            log.warning("interrupted at step %d: %s holds the run, continue it with --resume", run.step, out_dir / LAST)
        raise
    finally:
        bar.close()
    if logged_steps:
        _log_terms(run, running / logged_steps, optimizer, summaries, None, world, runner)
    seconds = time.perf_counter() - start_time
    return (run.step - start_step) / seconds if seconds > 0 else 0.0


def _step(cfg: TrainConfig, step: int, model, optimizer, runner, batch: dict, world) -> torch.Tensor:
    """One optimizer update on a batch of windows; returns the detached loss terms (``loss.terms`` order)."""
    window = batch["reference"].shape[1]
    loss_frames = window - cfg.burn_in
    bptt = cfg.bptt or loss_frames
    gt_history = cfg.uses_gt_history(step)
    state, valid = burn_in(model, batch, cfg.burn_in, gt_history, cfg.crop_mask)
    terms = torch.zeros(len(_chunk(runner).loss.terms))
    for t0 in range(cfg.burn_in, window, bptt):
        t1 = min(window, t0 + bptt)
        # accumulate gradients locally; the last chunk's backward all-reduces the sum
        sync = contextlib.nullcontext() if (t1 == window or not world.distributed) else runner.no_sync()
        with sync:
            loss, chunk_terms, state, valid = runner(batch, t0, t1, state, valid, gt_history, loss_frames, cfg.crop_mask)
            loss.backward()
        state = detach_state(state)
        terms += chunk_terms
    optimizer.step()
    optimizer.zero_grad(set_to_none=True)
    return terms


def _log_terms(run: RunState, mean_terms: torch.Tensor, optimizer, summaries: Summaries, bar, world, runner) -> None:
    if world.distributed:
        torch.distributed.all_reduce(mean_terms)
        mean_terms = mean_terms / world.size
    values = dict(zip(_chunk(runner).loss.terms, mean_terms.tolist()))
    run.recent_loss = values["total"]
    scalars = {f"loss/{k}": v for k, v in values.items()}
    scalars["lr"] = optimizer.param_groups[0]["lr"]
    summaries.scalars(run.step, scalars)
    if bar is not None:
        bar.set_postfix(loss=f"{values['total']:.4f}", refresh=False)


def _validate(cfg: TrainConfig, run: RunState, model, val_windows, indices: list[int], summaries: Summaries) -> None:
    scalars, images = validate(model, val_windows, indices, skip=cfg.burn_in)
    run.val_psnr = scalars["val/psnr"]
    summaries.scalars(run.step, scalars)
    summaries.images(run.step, images)
    floors = [f"{k[len('val/psnr_'):]} {v:.2f} dB" for k, v in scalars.items() if k.startswith("val/psnr_")]
    log.info("step %d: validation PSNR %.2f dB%s", run.step, scalars["val/psnr"], f" ({', '.join(floors)})" if floors else "")


def _chunk(runner) -> WindowChunk:
    """The :class:`WindowChunk` inside ``runner`` (wrapped by DistributedDataParallel or not)."""
    return runner.module if isinstance(runner, nn.parallel.DistributedDataParallel) else runner


def _set_lr(optimizer, cfg: TrainConfig, step: int) -> None:
    if cfg.lr_schedule == "constant":
        return
    progress = min(step / max(cfg.steps - 1, 1), 1.0)
    lr = cfg.lr_final + 0.5 * (cfg.lr - cfg.lr_final) * (1.0 + math.cos(math.pi * progress))
    for group in optimizer.param_groups:
        group["lr"] = lr


def _open_data(cfg: TrainConfig, world, progress: bool, family, frame_scale: bool = False):
    """Training windows (rank 0 builds the decoded cache, the others then open it) and rank 0's validation windows."""
    if world.is_main:
        windows = open_windows(cfg, cfg.train_dirs(), cfg.crop, progress, family, augment=True, frame_scale=frame_scale)
    distributed.barrier(world)
    if not world.is_main:
        windows = open_windows(cfg, cfg.train_dirs(), cfg.crop, False, family, augment=True, frame_scale=frame_scale)
    val = None
    if world.is_main and cfg.val_dirs():
        val = open_windows(cfg, cfg.val_dirs(), cfg.val_crop, progress, family, frame_scale=frame_scale)
    return windows, val


def takes_frame_scale(model_config) -> bool:
    """Whether the family's models read the frame key ``scale`` (docs/architecture.md): a model
    with ``takes_frame_scale = True``.  Asked of a model built for the purpose, with torch's
    random state put back, so the run's initial weights are those it always had."""
    with torch.random.fork_rng(devices=[]):
        return bool(getattr(build_model(model_config), "takes_frame_scale", False))


def data_scales(dirs: list[Path]) -> list:
    """The scales of the sequences under ``dirs`` (from meta.json: cheap, no cache), ascending."""
    from ..dataset.format import find_sequences, read_meta

    return sorted({read_meta(seq).scale for d in dirs for seq in find_sequences(d)})


def check_scales(model_config, scales: list, frame_scale: bool) -> None:
    """A one-line UserError unless the model can train on data of ``scales``: a model that reads
    the frame key ``scale`` takes any mix (its forward refuses a scale it cannot run); any other
    takes its own scale only."""
    from ..model.family import check_data_scale
    from ..ops.scale import scale_label

    if frame_scale or not scales:
        return
    family, model_scale = model_config.family, model_config.scale
    if len(scales) > 1:
        raise UserError(f"training data mixes scales {', '.join(scale_label(s) for s in scales)}, but the {family} family "
                        f"trains at one scale (x{model_scale}; its models read no frame 'scale', docs/architecture.md): "
                        "train one scale at a time")
    if not float(scales[0]).is_integer():
        check_data_scale(family, model_scale, scales[0], "training data")
    if scales[0] != model_scale:
        raise UserError(f"training data is x{scales[0]} but the model is x{model_scale}")


def _check_out_dir(out_dir: Path, resume: bool) -> None:
    for name in (LAST, FINAL):  # a run killed while saving leaves a temporary checkpoint
        remove_stale_leftovers(out_dir / name)
    if resume:
        if not (out_dir / LAST).is_file():
            raise UserError(f"nothing to resume: {out_dir / LAST} does not exist")
    elif (out_dir / LAST).exists() or (out_dir / FINAL).exists():
        raise UserError(f"{out_dir} already holds a training run (continue it with --resume, or choose another --out)")


# train: keys that change how a run is watched or scheduled on the machine, not the weights it ends with
BOOKKEEPING_KEYS = {"time_budget_min", "checkpoint_every", "log_every", "val_every", "val_windows", "val_crop", "val_data",
                    "log_dir", "num_workers", "threads", "cache_dir"}


def _check_resumable(record: dict, experiment: ExperimentConfig) -> None:
    changed = changed_train_keys(record.get("train") or {}, experiment.train, BOOKKEEPING_KEYS)
    if changed:
        log.warning("train.%s differs from the run being resumed; the result will differ from an uninterrupted run", changed[0])


def _record(experiment: ExperimentConfig, windows) -> dict:
    """The caller's part of the checkpoint record (the model part is added by ``checkpoint``)."""
    patterns = sorted({s.meta.jitter_pattern for s in windows.sequences})
    if len(patterns) > 1:
        log.warning("training sequences use several jitter patterns: %s", ", ".join(patterns))
    return {
        "jitter_pattern": patterns[0] if len(patterns) == 1 else ",".join(patterns),
        "train_scales": list(windows.scales),  # the scales of the training data (several: one per batch)
        "data_fingerprint": windows.fingerprint(),
        "train": to_dict(experiment.train),
        "data": to_dict(experiment.data) if experiment.data else None,
        "training": None,
    }


def _spread(count: int, wanted: int) -> list[int]:
    """Up to ``wanted`` indices spread evenly over ``range(count)``."""
    if count <= wanted:
        return list(range(count))
    return [round(i * (count - 1) / (wanted - 1)) if wanted > 1 else 0 for i in range(wanted)]
