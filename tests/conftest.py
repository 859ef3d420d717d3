"""Fixtures shared by every stage's tests."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from mnss_kit.dataset.synthetic import write_synthetic_sequence

sys.path.insert(0, str(Path(__file__).resolve().parent / "android"))  # the Java harness, for every test directory
from java_harness import JavaCore, compile_core, compile_gl_pipeline, missing_jogl, missing_tools  # noqa: E402


@pytest.fixture(scope="session")
def java_core(tmp_path_factory) -> JavaCore:
    reason = missing_tools()
    if reason:
        pytest.skip(reason)
    return compile_core(tmp_path_factory.mktemp("android_core_classes"))


@pytest.fixture(scope="session")
def gl_classes(tmp_path_factory) -> Path:
    """The core and android/gljogl (the JOGL binding) compiled; skips without JOGL."""
    reason = missing_jogl()
    if reason:
        pytest.skip(reason)
    return compile_gl_pipeline(tmp_path_factory.mktemp("gl_pipeline_classes"))


def pytest_configure(config):
    # Test tensors are tiny: a single intra-op thread avoids OpenMP spin-up and contention,
    # which on a 2-core machine costs more than the work itself.
    import torch

    torch.set_num_threads(1)


SYNTHETIC_LR_SIZE = (32, 24)  # (width, height)
SYNTHETIC_SCALE = 2
SYNTHETIC_FRAMES = 8
SYNTHETIC_CUT_AT = 5


@pytest.fixture(scope="session")
def synthetic_dataset(tmp_path_factory) -> Path:
    """A dataset directory holding two analytic sequences; treat it as read-only (copy it to change it).

    ``pan``: 8 frames of a panning camera and a moving square, LR 32x24 -> HR 64x48 (scale 2,
    grid jitter), reset only on frame 0.  ``pan_cut``: the same scene with a camera cut at
    frame 5 (reset on frames 0 and 5).  Buffers: lr color/depth/motion, hr reference/depth/motion.
    Loaders writing a cache should be given a ``cache_dir`` outside this directory.
    """
    root = tmp_path_factory.mktemp("synthetic_dataset")
    common = dict(lr_size=SYNTHETIC_LR_SIZE, scale=SYNTHETIC_SCALE, frames=SYNTHETIC_FRAMES)
    write_synthetic_sequence(root / "pan", name="pan", **common)
    write_synthetic_sequence(root / "pan_cut", name="pan_cut", cut_at=SYNTHETIC_CUT_AT, **common)
    return root
