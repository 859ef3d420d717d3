"""The grid jitter pattern was called ``mnss``: the old spelling is still read where a user or a file
on disk gives it (data configs, ``--set jitter=...``, ``meta.json``, import mappings), means the same
offsets, and logs one deprecation line naming the new spelling; what is written uses the new name."""

from __future__ import annotations

import json
import logging

import numpy as np
import pytest

from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.errors import UserError
from mnss_kit.ops.jitter import PATTERNS, RENAMED_PATTERNS, jitter_sequence, pattern_name, period
from mnss_kit.render.config import load_render_config

CONFIG = "version: 1\ndefaults: {frames: 3, lr_size: [32, 18]}\nsequences:\n  - {name: a, scene: arena, jitter: %s}\n"


@pytest.fixture
def fresh_warning(monkeypatch):
    """Each test sees the deprecation line as a new process would (it is logged once per process)."""
    monkeypatch.setattr(fmt, "_TOLD_RENAMED", set())


def deprecations(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING and "now called" in r.getMessage()]


def test_the_old_name_is_no_pattern_of_its_own_but_gives_the_same_offsets():
    assert RENAMED_PATTERNS == {"mnss": "grid"} and "mnss" not in PATTERNS and "grid" in PATTERNS
    assert pattern_name("mnss") == "grid" and pattern_name("halton") == "halton" and pattern_name("nss") == "nss"
    for scale in (2, 3):
        assert period("mnss", scale) == period("grid", scale)
        np.testing.assert_array_equal(jitter_sequence("mnss", scale, 20), jitter_sequence("grid", scale, 20))
    with pytest.raises(UserError, match="grid jitter pattern exists for scales 2 and 3"):
        period("mnss", 4)


def test_a_data_config_and_set_with_the_old_name_read_as_grid_with_one_deprecation_line(tmp_path, caplog, fresh_warning):
    path = tmp_path / "cfg.yaml"
    path.write_text(CONFIG % "mnss")
    with caplog.at_level(logging.WARNING):
        assert [s.jitter for s in load_render_config(str(path)).sequences] == ["grid"]
        path.write_text(CONFIG % "halton")
        assert [s.jitter for s in load_render_config(str(path), ["jitter=mnss"]).sequences] == ["grid"]
        assert [s.jitter for s in load_render_config(str(path), ["a.jitter=mnss"]).sequences] == ["grid"]
    lines = deprecations(caplog)
    assert len(lines) == 1, lines
    assert "'mnss' is now called 'grid'" in lines[0] and "write 'grid'" in lines[0]


def test_the_new_name_logs_nothing(tmp_path, caplog, fresh_warning):
    path = tmp_path / "cfg.yaml"
    path.write_text(CONFIG % "grid")
    with caplog.at_level(logging.WARNING):
        assert [s.jitter for s in load_render_config(str(path)).sequences] == ["grid"]
    assert deprecations(caplog) == []


def test_a_dataset_written_with_the_old_name_reads_as_grid(tmp_path, caplog, fresh_warning):
    seq = write_synthetic_sequence(tmp_path / "seq", frames=6, pattern="grid")
    meta_path = seq / fmt.META_FILE
    meta = json.loads(meta_path.read_text())
    assert meta["jitter_pattern"] == "grid"  # what is written
    meta["jitter_pattern"] = "mnss"  # as a dataset rendered before the rename
    meta_path.write_text(json.dumps(meta))
    with caplog.at_level(logging.WARNING):
        read = fmt.read_meta(seq)
        fmt.read_meta(seq)
    assert read.jitter_pattern == "grid"
    assert [f.jitter for f in read.frames] == [tuple(j) for j in jitter_sequence("grid", 2, 6)]
    assert len(deprecations(caplog)) == 1


def test_a_render_on_top_of_one_from_before_the_rename_resumes(tmp_path):
    """The renderer compares the meta.json on disk with its own: the old name is the same config."""
    from mnss_kit.render.run import _prepare_meta

    seq = write_synthetic_sequence(tmp_path / "seq", frames=3, pattern="grid")
    meta = fmt.read_meta(seq)
    meta.scene = {**meta.scene, "jitter": "grid"}
    fmt.write_meta(seq, meta)
    on_disk = json.loads((seq / fmt.META_FILE).read_text())
    old = {**on_disk, "jitter_pattern": "mnss", "scene": {**on_disk["scene"], "jitter": "mnss"}}
    (seq / fmt.META_FILE).write_text(json.dumps(old))
    _prepare_meta(seq, meta, overwrite=False)  # no "rendered with a different config"
    assert json.loads((seq / fmt.META_FILE).read_text())["jitter_pattern"] == "mnss"  # left as written
    meta.jitter_pattern = "halton"
    with pytest.raises(UserError, match="different config"):
        _prepare_meta(seq, meta, overwrite=False)
