"""The factory scene, the stand-in for a studio's game in docs/training.md's worked example: it renders
every buffer through the renderer, passes data check, and stays out of the default training set."""

from __future__ import annotations

import numpy as np

from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.check import check_dataset
from mnss_kit.render.config import SequenceConfig, load_render_config
from mnss_kit.render.scenes import build_scene
from mnss_kit.render.run import render_dataset

CONFIG = """
version: 1
defaults: {lr_size: [48, 27], scale: 2, jitter: grid, hr_samples: 1, fps: 30, frames: 3}
sequences:
  - {name: factory, scene: factory, seed: 3, particles: true, animated_light: true}
"""


def test_factory_renders_every_buffer_and_passes_data_check(tmp_path):
    (tmp_path / "tiny.yaml").write_text(CONFIG)
    render_dataset(load_render_config(str(tmp_path / "tiny.yaml")), tmp_path / "out", progress=False)
    seq = tmp_path / "out" / "factory"
    report = check_dataset(tmp_path / "out", progress=False)
    assert not report.errors, [p.line() for p in report.errors]
    meta = fmt.read_meta(seq)
    assert meta.frame_count == 3 and meta.scene["scene"] == "factory"
    for res, size in (("lr", (27, 48)), ("hr", (54, 96))):
        for name in meta.buffers[res]:
            image = fmt.read_raw_buffer(seq, res, name, 2)
            assert image.shape[:2] == size and np.all(np.isfinite(image)), (res, name)


def test_factory_is_an_interior_lit_through_the_roof():
    scene = build_scene(SequenceConfig(name="f", scene="factory", seed=5, frames=48), load_render_config("studio_x2"))
    lo, hi = np.min([m.positions.min(0) for m in scene.meshes], 0), np.max([m.positions.max(0) for m in scene.meshes], 0)
    for k in range(0, 48, 6):  # the generated camera stays inside the hall
        position = scene.camera.state(k / 30).position
        assert np.all(position > lo) and np.all(position < hi)
    assert scene.camera.cut_times  # a hard cut, as in the training set's paths
    assert max(max(m.material.emissive) for m in scene.meshes) > 1.0  # strip lights
    assert max(scene.sky.zenith) < 0.1  # dim ambient: the sun enters through the skylight slots


def test_studio_set_holds_a_scene_family_the_default_training_set_lacks():
    studio, default = load_render_config("studio_x2").sequences, load_render_config("train_x2").sequences
    assert {s.scene for s in studio} == {"factory"} and "factory" not in {s.scene for s in default}
    assert 4 <= len(studio) <= 6
    shared = ("lr_size", "scale", "jitter", "hr_samples", "fps", "camera")
    assert {tuple(getattr(s, k) for k in shared) for s in studio} == {tuple(getattr(s, k) for k in shared) for s in default}
