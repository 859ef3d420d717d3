"""Tiny model and training sections for the training tests."""

from __future__ import annotations

from pathlib import Path

TINY_MODEL = {"family": "mnss", "scale": 2, "recon_width": 8, "recon_layers": 2, "aa_width": 4, "aa_layers": 1}


def tiny_train_section(dataset: Path, cache_dir: Path, **changes) -> dict:
    """A ``train:`` section that runs in well under a second per step on one thread."""
    section = {
        "train_data": str(dataset),
        "window": 3,
        "batch_size": 2,
        "crop": 12,
        "epochs": 2,
        "steps_per_epoch": 6,
        "gt_history_epochs": 1,
        "bptt": 2,
        "threads": 1,
        "log_every": 3,
        "checkpoint_every": 3,
        "val_every": 0,
        "cache_dir": str(cache_dir),
    }
    section.update(changes)
    return section
