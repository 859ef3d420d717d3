"""Fixtures: a tiny exported bundle (the compiled Java core and GL pipeline are tests/conftest.py's).

Without a JDK (javac 17 or newer) or the JUnit 4 and Hamcrest jars every test here is skipped with
the reason; CI installs them (scripts/setup.sh).
"""

from __future__ import annotations

from pathlib import Path

import pytest


BUNDLE_SIZE = "64x48"  # the synthetic dataset's HR size: its frames become the golden frames
from recorded_sequence import SEQUENCE_FRAMES


@pytest.fixture(scope="session")
def tiny_bundle(tmp_path_factory, synthetic_dataset) -> Path:
    """A bundle written by ``mnss-kit export`` from an untrained mnss_x2_tiny checkpoint (last convs
    perturbed so every tensor carries signal) at 64x48, golden frames and a recorded 6-frame sequence
    from the synthetic dataset.
    Read-only: copy it before changing it."""
    import torch

    from mnss_kit.cli import main
    from mnss_kit.model import checkpoint
    from mnss_kit.model.config import load_model_config
    from mnss_kit.model.families import build_model, randomise_convs

    root = tmp_path_factory.mktemp("android_bundle")
    torch.manual_seed(0)
    model = build_model(load_model_config("mnss_x2_tiny")).eval()
    randomise_convs(model)
    ckpt = checkpoint.save(root / "mnss_x2_tiny.pt", model, {"jitter_pattern": "grid"})
    out = root / "bundle"
    code = main(["export", str(ckpt), "--out", str(out), "--resolution", BUNDLE_SIZE, "--data", str(synthetic_dataset),
                 "--sequence", str(synthetic_dataset), "--frames", str(SEQUENCE_FRAMES), "--no-progress"])
    assert code == 0
    return out
