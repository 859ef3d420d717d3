"""A capture split in time: the first frames of each sequence to tune on, the rest to judge on.

The judged part starts ``warmup`` frames before the held-back frames, so every method enters them
with a history, as it would in a game; those warm-up frames are run but not scored.  Frame files
are hard-linked where the filesystem allows (copied otherwise) under new, gap-free indices.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from ..dataset import format as fmt
from ..errors import UserError
from ..fileio import atomic_directory


@dataclass(frozen=True)
class SequenceSplit:
    name: str
    frames: int
    tune: range  # frame indices of the source sequence trained on
    judged: range  # frame indices run for the judgement: warm-up frames, then the held-back ones
    warmup: int

    @property
    def held_back(self) -> range:
        return self.judged[self.warmup:]


def plan_split(seq: Path, meta: fmt.SequenceMeta, hold_back: float, warmup: int, min_tune: int, min_judged: int = 2) -> SequenceSplit:
    """Where one sequence splits; a one-line UserError when it is too short to split usefully."""
    n = meta.frame_count
    first_held = n - int(round(n * hold_back))
    if first_held < min_tune or n - first_held < min_judged:
        raise UserError(f"{seq}: too short to split: its {n} frame(s) give {first_held} to tune on and {n - first_held} "
                        f"held back (--hold-back {hold_back}); fine-tuning needs at least {min_tune} and {min_judged}")
    start = max(first_held - warmup, 0)
    return SequenceSplit(seq.name, n, range(0, first_held), range(start, n), first_held - start)


def write_split(sequences: list[Path], splits: list[SequenceSplit], tune_dir: Path, judge_dir: Path) -> None:
    """The tune and judge datasets of ``splits`` (each written atomically, once)."""
    for out, part in ((tune_dir, "tune"), (judge_dir, "judged")):
        if out.is_dir():
            continue
        with atomic_directory(out) as staging:
            for seq, split in zip(sequences, splits):
                write_part(seq, staging / seq.name, getattr(split, part))


def write_part(src: Path, dst: Path, frames: range) -> None:
    """Frames ``frames`` of the sequence ``src`` as a sequence of their own in ``dst``, numbered from 0
    (the first one a reset: the part starts with no history)."""
    meta = fmt.read_meta(src)
    for res, names in meta.buffers.items():
        for name in names:
            for new, old in enumerate(frames):
                _link_or_copy(fmt.buffer_path(src, res, name, old), fmt.buffer_path(dst, res, name, new))
    kept = [meta.frames[i] for i in frames]
    renumbered = [dataclasses.replace(f, index=new, reset=f.reset or new == 0) for new, f in enumerate(kept)]
    fmt.write_meta(dst, fmt.replace_meta(meta, frames=renumbered))


def _link_or_copy(src: Path, dst: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)
