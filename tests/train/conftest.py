"""Tiny experiment configs on the shared synthetic dataset, for fast training tests."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from train_helpers import TINY_MODEL, tiny_train_section


@pytest.fixture
def write_experiment(tmp_path, synthetic_dataset):
    """``write_experiment(**train_changes) -> path`` of a tiny experiment YAML in ``tmp_path``."""
    cache_dir = tmp_path / "cache"

    def write(name: str = "tiny.yaml", model: dict | None = None, **train_changes) -> Path:
        doc = {"schema": 1, "model": model or dict(TINY_MODEL), "train": tiny_train_section(synthetic_dataset, cache_dir, **train_changes)}
        path = tmp_path / name
        path.write_text(yaml.safe_dump(doc))
        return path

    return write
