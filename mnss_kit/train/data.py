"""Training data: rendering missing data, and a window stream that can be resumed at any step.

The stream.  Each rank sees an endless sequence of ``(pass, window index)``
draws: pass ``p`` is ``DistributedSampler(shuffle=True, seed=seed)`` at epoch
``p`` over all windows, so the ranks read disjoint shards of every pass, and
the crop of a window is drawn by the dataset from ``(seed, p, index)``.  Step
``s`` of a rank consumes draws ``s*B .. s*B + B - 1`` of its stream.  The
whole stream is a function of (seed, world size, batch size), not of the
worker processes or of earlier runs, so resuming at step ``s`` only needs
``s`` and reads exactly the windows and crops an uninterrupted run would.

Several scales (``groups``: the windows of each scale, ``WindowDataset.window_groups``).  A
batch stacks windows of one scale, so each step first draws its group: step ``s`` takes group
``g`` with probability proportional to the group's window count, drawn from ``(seed, s // 256)``
(the same on every rank, so the replicas of a step run one scale).  Each group then has its own
stream as above over its windows (pass ``p`` = ``DistributedSampler`` over the group at epoch
``p``); a step of group ``g`` consumes the next ``B`` draws of that group's stream, those that
the group's earlier steps left.  The stream stays a function of (seed, world size, batch size):
resuming at step ``s`` counts each group's earlier steps from the same draws.  With one group
this is the stream above, draw for draw.
"""

from __future__ import annotations

import logging
import shutil
from pathlib import Path
from typing import Iterator

import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset, DistributedSampler, Sampler

from ..dataset.loader import WindowDataset
from ..errors import UserError
from .config import DataSection, TrainConfig

log = logging.getLogger(__name__)


GROUP_BLOCK = 256  # steps whose groups one generator draws: step s's group comes from (seed, s // GROUP_BLOCK)


class StepSampler(Sampler):
    """``(pass, index)`` draws of one rank for steps ``start_step .. end_step - 1`` (``batch_size`` per step).

    ``groups``: the window indices of each group (scale); every step's draws come from one group.
    None (or one group): all ``windows`` form one group."""

    def __init__(self, windows: int, batch_size: int, rank: int, world_size: int, seed: int, start_step: int, end_step: int,
                 groups: list[list[int]] | None = None):
        self.windows, self.batch_size = windows, batch_size
        self.rank, self.world_size, self.seed = rank, world_size, seed
        self.start_step, self.end_step = start_step, end_step
        self.groups = [list(g) for g in groups] if groups is not None and len(groups) > 1 else None
        if self.groups is not None:
            if any(not g for g in self.groups) or sorted(i for g in self.groups for i in g) != list(range(windows)):
                raise ValueError("groups must partition range(windows) into non-empty groups")
            sizes = np.array([len(g) for g in self.groups], dtype=np.float64)
            self.weights = sizes / sizes.sum()
        self.per_pass = len(self._pass(0))

    def _pass(self, p: int, count: int | None = None) -> list[int]:
        count = self.windows if count is None else count
        shard = DistributedSampler(range(count), num_replicas=self.world_size, rank=self.rank, shuffle=True, seed=self.seed)
        shard.set_epoch(p)
        return list(shard)

    def step_groups(self, start: int, end: int) -> np.ndarray:
        """The group of each step ``start .. end - 1`` (all 0 with one group)."""
        if self.groups is None:
            return np.zeros(max(0, end - start), dtype=np.int64)
        blocks = [np.random.default_rng([self.seed, 0x5CA1E, b]).choice(len(self.groups), GROUP_BLOCK, p=self.weights)
                  for b in range(start // GROUP_BLOCK, -(-end // GROUP_BLOCK))]
        drawn = np.concatenate(blocks) if blocks else np.zeros(0, dtype=np.int64)
        first = (start // GROUP_BLOCK) * GROUP_BLOCK
        return drawn[start - first:end - first]

    def __len__(self) -> int:
        return max(0, self.end_step - self.start_step) * self.batch_size

    def __iter__(self) -> Iterator[tuple[int, int]]:
        if self.groups is None:
            yield from self._stream(self.start_step * self.batch_size, len(self), self.windows, None)
            return
        # each group's stream resumes after the draws of its steps before start_step
        done = np.bincount(self.step_groups(0, self.start_step), minlength=len(self.groups))
        streams = [self._stream(int(done[g]) * self.batch_size, None, len(members), members)
                   for g, members in enumerate(self.groups)]
        for g in self.step_groups(self.start_step, self.end_step):
            for _ in range(self.batch_size):
                yield next(streams[g])

    def _stream(self, first: int, count: int | None, size: int, members: list[int] | None) -> Iterator[tuple[int, int]]:
        """Draws ``first ..`` (``count`` of them, or endless) of the stream over ``size`` windows;
        ``members`` maps the stream's positions to window indices (None: the identity)."""
        per_pass = len(self._pass(0, size))
        p, offset = divmod(first, per_pass)
        remaining = count
        while remaining is None or remaining > 0:
            order = self._pass(p, size)[offset:]
            if remaining is not None:
                order = order[:remaining]
                remaining -= len(order)
            for index in order:
                yield p, index if members is None else members[index]
            p, offset = p + 1, 0


class PassWindows(Dataset):
    """Wraps a ``WindowDataset`` so an item ``(pass, index)`` gets the crop drawn for that pass."""

    def __init__(self, windows: WindowDataset):
        self.windows = windows

    def __len__(self) -> int:
        return len(self.windows)

    def __getitem__(self, draw: tuple[int, int]) -> dict[str, torch.Tensor]:
        p, index = draw
        self.windows.set_epoch(p)
        return self.windows[index]


def open_windows(cfg: TrainConfig, dirs: list[Path], crop: int | None, progress: bool,
                 family=None, augment: bool = False, frame_scale: bool = False) -> WindowDataset:
    """The windows of ``dirs`` with the decoded-frame cache (built on first use), with the G-buffers
    ``family`` (a ``model.family.Family``, or None: the base buffers only) reads; ``augment``: the
    config's ``train.augment`` (training windows only); ``frame_scale``: the model reads the frame
    key ``scale`` (docs/architecture.md), so the data may mix scales and every window carries it."""
    size = None if crop is None else (crop, crop)
    hr_buffers = tuple(family.hr_inputs) if family else ()
    if augment and cfg.augment.get("taa_reference", 0.0) > 0.0:  # a window may take the native TAA render as its target
        hr_buffers += ("reference_taa",)
    return WindowDataset([str(d) for d in dirs], cfg.frames_per_window, size, seed=cfg.seed, cache=True, cache_dir=cfg.cache_dir,
                         progress=progress,
                         hr_buffers=hr_buffers, lr_buffers=family.lr_buffers if family else (),
                         needed_by=f"the {family.name} family" if family else "", augment=cfg.augment if augment else None,
                         mixed_scales=frame_scale, with_scale=frame_scale)


def step_loader(windows: WindowDataset, cfg: TrainConfig, rank: int, world_size: int, start_step: int) -> DataLoader:
    """Batches of ``cfg.batch_size`` windows for steps ``start_step .. cfg.steps - 1`` of this rank."""
    groups = list(windows.window_groups().values())  # one scale per batch
    sampler = StepSampler(len(windows), cfg.batch_size, rank, world_size, cfg.seed, start_step, cfg.steps, groups)
    return DataLoader(
        PassWindows(windows),
        batch_size=cfg.batch_size,
        sampler=sampler,
        num_workers=cfg.num_workers,
        persistent_workers=False,
        prefetch_factor=4 if cfg.num_workers else None,
        drop_last=False,
    )


def ensure_data(cfg: TrainConfig, data: DataSection | None, progress: bool = True) -> None:
    """Render the training (and validation) data named in ``data:`` when its directory is missing."""
    wanted = [("train", cfg.train_dirs(), data.train if data else None), ("val", cfg.val_dirs(), data.val if data else None)]
    for role, dirs, render_config in wanted:
        missing = [d for d in dirs if not d.exists()]
        if not missing:
            continue
        if render_config is None:
            raise UserError(f"{role} data {missing[0]} does not exist and the config's data: section names no render config for it")
        configs = [render_config] if isinstance(render_config, str) else list(render_config)
        if len(configs) != len(dirs):
            raise UserError(f"data.{role} names {len(configs)} render config(s) for the {len(dirs)} director(ies) of "
                            f"train.{role}_data (one each, in order)")
        for directory, config in zip(dirs, configs):
            if not directory.exists():
                render(config, directory, progress)


def render(render_config: str, out_dir: Path, progress: bool) -> None:
    """Render the data config ``render_config`` into ``out_dir``: a path or a name under
    mnss_kit/configs/data/, optionally followed by overrides (``train_x2 jitter=center``) and by
    ``variant=NAME[,NAME]`` (``mnss-kit data variant --apply``: the render rewritten as an engine
    would send it; the clean render is kept beside it as ``OUT.source`` until the variant is written)."""
    try:
        from ..render.config import load_render_config
        from ..render.run import render_dataset
    except ImportError as e:
        raise UserError(f"cannot render {out_dir}: the renderer is not available in this installation ({e})") from None
    name, *overrides = render_config.split()
    variants = [v for o in overrides if o.startswith("variant=") for v in o[len("variant="):].split(",") if v]
    overrides = [o for o in overrides if not o.startswith("variant=")]
    if variants:
        from ..dataset.variants import write_variant_dataset

        source = out_dir.with_name(out_dir.name + ".source")
        render(" ".join([name, *overrides]), source, progress)
        log.info("writing the %s variant of %s into %s", ",".join(variants), source, out_dir)
        write_variant_dataset(source, out_dir, variants)
        shutil.rmtree(source)
        return
    cfg = load_render_config(name, overrides or None)
    # Render beside the target and rename when complete: a killed render never looks like data,
    # and the next run continues it (the renderer skips frames already written).
    staging = out_dir.with_name(out_dir.name + ".partial")
    log.info("rendering %s into %s", render_config, out_dir)
    summary = render_dataset(cfg, staging, progress=progress)
    staging.replace(out_dir)
    log.info("rendered %d frames in %.1f s", summary.rendered, summary.seconds)
