"""The native-AA references (hr/reference_taa, hr/reference_4x): convergence, softness, data check, resume."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.check import check_dataset
from mnss_kit.metrics.psnr import psnr
from mnss_kit.render.config import load_render_config
from mnss_kit.render.run import render_dataset


def files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}

CONFIG = """
version: 1
defaults: {lr_size: [64, 36], scale: 2, hr_samples: 16, extra_references: [taa, 4x]}
sequences:
  - {name: still, scene: arena, seed: 11, camera: still, start_time: 0.5, frames: 32}
  - {name: pan, scene: arena, seed: 11, camera: pan.yaml, start_time: 0.5, frames: 16}
"""
# a steady pan and turn, no cut: about 2 HR pixels of motion per frame
PAN = """
keyframes:
  - {time: 0.5, position: [-10, 14, 12], look_at: [-9, 0, 0]}
  - {time: 1.1, position: [-4, 14, 11], look_at: [-3, 0, 0]}
"""


@pytest.fixture(scope="module")
def config(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("native_cfg")
    (root / "pan.yaml").write_text(PAN)
    (root / "native.yaml").write_text(CONFIG)
    return root / "native.yaml"


@pytest.fixture(scope="module")
def rendered(config, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("native_out")
    render_dataset(load_render_config(str(config)), out, progress=False)
    return out


def display(seq: Path, buffer: str, index: int) -> np.ndarray:
    return fmt.read_buffer(seq, fmt.read_meta(seq), "hr", buffer, index)


def mean_gradient(image: np.ndarray) -> float:
    """Mean magnitude of the forward differences of a display image: the softness measure."""
    return float(np.mean(np.hypot(np.diff(image, axis=1)[:-1], np.diff(image, axis=0)[:, :-1])))


def gradient_ratio(seq: Path, buffer: str, index: int) -> float:
    return mean_gradient(display(seq, buffer, index)) / mean_gradient(display(seq, "reference", index))


def test_meta_lists_the_references_and_how_they_were_made(rendered):
    meta = fmt.read_meta(rendered / "pan")
    assert meta.buffers["hr"][-2:] == ["reference_taa", "reference_4x"]
    assert meta.scene["extra_references"] == ["taa", "4x"]
    assert "Halton(2,3) 8 phases" in meta.scene["reference_taa"]


def test_data_check_passes_without_warnings(rendered):
    report = check_dataset(rendered, progress=False)
    assert not report.problems, [p.line() for p in report.problems]
    assert report.files == 48 * 20  # 9 LR + 11 HR buffers per frame


def test_static_camera_taa_converges_to_the_box_reference(rendered):
    seq = rendered / "still"
    assert psnr(display(seq, "reference_taa", 0), display(seq, "reference", 0)) < 37  # one aliased sample
    assert psnr(display(seq, "reference_taa", 31), display(seq, "reference", 31)) > 40  # measured 41.2 dB


def test_moving_camera_taa_is_softer_than_the_box_and_than_a_static_one(rendered):
    """Mean gradient magnitude relative to the box reference, frames 8-15 (history built up)."""
    moving = np.median([gradient_ratio(rendered / "pan", "reference_taa", t) for t in range(8, 16)])
    still = np.median([gradient_ratio(rendered / "still", "reference_taa", t) for t in range(8, 16)])
    assert moving < 0.93 and moving < still - 0.03, (moving, still)


def test_four_sample_reference_is_close_to_the_box_and_as_sharp(rendered):
    for name in ("still", "pan"):
        seq = rendered / name
        assert psnr(display(seq, "reference_4x", 5), display(seq, "reference", 5)) > 38
        assert 0.97 < gradient_ratio(seq, "reference_4x", 5) < 1.05


def test_shards_and_resume_reproduce_the_taa_history(config, rendered, tmp_path):
    cfg = load_render_config(str(config), ["pan.frames=16", "still.frames=2"])
    cfg.sequences = [s for s in cfg.sequences if s.name == "pan"]
    merged = tmp_path / "merged"
    for i in range(2):
        render_dataset(cfg, tmp_path / f"part{i}", shard=(i, 2), progress=False)
        shutil.copytree(tmp_path / f"part{i}", merged, dirs_exist_ok=True)
    assert files(merged / "pan") == files(rendered / "pan")
    for index in range(9, 16):  # an interrupted run: the later frames of one buffer are missing
        fmt.buffer_path(merged / "pan", "hr", "reference_taa", index).unlink()
    summary = render_dataset(cfg, merged, progress=False)
    assert summary.rendered == 7
    assert files(merged / "pan") == files(rendered / "pan")


def test_without_the_key_no_reference_is_added(tiny_render):
    meta = fmt.read_meta(tiny_render / "arena")
    assert "reference_taa" not in meta.buffers["hr"] and "extra_references" not in meta.scene
    assert not (tiny_render / "arena" / "hr" / "reference_taa").exists()
