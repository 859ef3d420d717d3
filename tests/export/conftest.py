"""One small bundle per session: the tiny MNSS x2 config with perturbed weights, exported at 64x48
from the synthetic dataset (which also gives the golden frames and a recorded 6-frame sequence).  Copy it before changing it."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

BUNDLE_SIZE = "64x48"  # the synthetic dataset's HR size, so its frames serve as golden frames
from recorded_sequence import SEQUENCE_FRAMES


def tiny_checkpoint(path: Path, seed: int = 0) -> Path:
    """An untrained mnss_x2_tiny checkpoint with random AA and reconstruction weights
    (``model.families.randomise_convs``)."""
    import torch
    
    from mnss_kit.model import checkpoint
    from mnss_kit.model.config import load_model_config
    from mnss_kit.model.families import build_model, randomise_convs

    torch.manual_seed(seed)
    model = randomise_convs(build_model(load_model_config("mnss_x2_tiny")).eval())
    return checkpoint.save(path, model, {"jitter_pattern": "grid"})


@pytest.fixture(scope="session")
def tiny_ckpt(tmp_path_factory) -> Path:
    return tiny_checkpoint(tmp_path_factory.mktemp("export_model") / "tiny.pt")


@pytest.fixture(scope="session")
def bundle(tmp_path_factory, tiny_ckpt, synthetic_dataset) -> Path:
    """A bundle written by ``mnss-kit export`` (the CLI entry) with a recorded sequence, read-only."""
    from mnss_kit.cli import main

    out = tmp_path_factory.mktemp("export_bundle") / "bundle"
    code = main(["export", str(tiny_ckpt), "--out", str(out), "--resolution", BUNDLE_SIZE, "--data", str(synthetic_dataset),
                 "--device", "snapdragon_8_gen_1", "--sequence", str(synthetic_dataset), "--frames", str(SEQUENCE_FRAMES), "--no-progress"])
    assert code == 0
    return out


@pytest.fixture
def bundle_copy(bundle, tmp_path) -> Path:
    """A private copy of the session bundle, free to change."""
    return Path(shutil.copytree(bundle, tmp_path / "bundle"))
