"""Tiny rendered sequences shared by the renderer tests (rendered once per session)."""

from __future__ import annotations

from pathlib import Path

import pytest

TINY_CONFIG = """
version: 1
defaults: {lr_size: [64, 36], scale: 2, jitter: grid, hr_samples: 16, fps: 30, frames: 4}
sequences:
  - {name: arena, scene: arena, seed: 11, particles: true, start_time: 0.5, camera: cam.yaml}
  - {name: town, scene: town, seed: 12, animated_light: true, frames: 3, start_time: 0.3}
"""

# a steady pan and turn: a few HR pixels of motion per frame, no cut
TINY_CAMERA = """
keyframes:
  - {time: 0.5, position: [-10, 14, 12], look_at: [-9, 0, 0]}
  - {time: 0.7, position: [-6, 14, 11], look_at: [-4, 0, 0]}
"""


@pytest.fixture(scope="session")
def tiny_config(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("render_cfg")
    (root / "cam.yaml").write_text(TINY_CAMERA)
    path = root / "tiny.yaml"
    path.write_text(TINY_CONFIG)
    return path


@pytest.fixture(scope="session")
def tiny_render(tiny_config, tmp_path_factory) -> Path:
    """The tiny config rendered once; read-only for the tests."""
    from mnss_kit.render.config import load_render_config
    from mnss_kit.render.run import render_dataset

    out = tmp_path_factory.mktemp("render_out")
    render_dataset(load_render_config(str(tiny_config)), out, progress=False)
    return out
