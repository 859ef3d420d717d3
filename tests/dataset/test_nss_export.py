"""Writing toolkit sequences as an NSS capture (``mnss_kit.dataset.nss_export``): the refusals and the
half-float range of the stored motion.  The full round trip through the importer is in
test_import_nss_render.py."""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.dataset.exr import read_exr
from mnss_kit.dataset.format import read_raw_buffer, write_buffer
from mnss_kit.dataset.importers.nss import import_nss
from mnss_kit.dataset.nss_export import HALF_MAX, export_nss
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.errors import UserError
from mnss_kit.render.config import load_render_config
from mnss_kit.render.run import render_dataset

CONFIG = """
version: 1
defaults: {lr_size: [16, 9], scale: 2, jitter: grid, hr_samples: 1, fps: 30, frames: 2}
sequences:
  - {name: a, scene: arena, seed: 1}
  - {name: b, scene: arena, seed: 2}
"""


@pytest.fixture
def rendered(tmp_path):
    (tmp_path / "tiny.yaml").write_text(CONFIG)
    render_dataset(load_render_config(str(tmp_path / "tiny.yaml")), tmp_path / "render", progress=False)
    return [tmp_path / "render" / "a", tmp_path / "render" / "b"]


def test_sequences_become_numbered_nss_sequences_and_motion_beyond_half_range_is_clamped(rendered, tmp_path):
    huge = read_raw_buffer(rendered[1], "hr", "motion", 1)
    huge[0, 0] = (1e9, -1e9)  # a point that barely stayed in front of the previous camera
    write_buffer(rendered[1], "hr", "motion", 1, huge)
    assert export_nss(rendered, tmp_path / "capture") == ["0000", "0001"]
    assert sorted(p.name for p in (tmp_path / "capture").glob("*.json")) == ["0000.json", "0001.json"]
    stored = read_exr(tmp_path / "capture" / "motion_gt" / "0001" / "0001.exr", ("R", "G"))
    assert np.all(np.isfinite(stored)) and tuple(stored[0, 0]) == (HALF_MAX, -HALF_MAX)
    np.testing.assert_allclose(stored[1:], huge[1:] / np.float32([32, 18]), rtol=2.0**-11, atol=2.0**-24)
    result = import_nss(tmp_path / "capture", tmp_path / "imported")
    assert result.sequences == 2 and result.frames == 4


def test_a_sequence_of_other_conventions_is_refused_and_nothing_is_written(tmp_path):
    seq = write_synthetic_sequence(tmp_path / "synthetic", frames=2)  # linear depth, not the renderer's
    with pytest.raises(UserError, match="depth convention"):
        export_nss([seq], tmp_path / "capture")
    assert not (tmp_path / "capture").exists()
