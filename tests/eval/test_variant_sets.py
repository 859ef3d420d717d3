"""A held-out set in an input variant is rewritten when its source set has grown since."""

from __future__ import annotations

import shutil

from mnss_kit.dataset import format as fmt
from mnss_kit.eval.variant_sets import variant_set


def test_a_rewritten_variant_follows_its_source_when_it_gains_a_sequence(synthetic_dataset, tmp_path):
    base = tmp_path / "base"
    base.mkdir()
    shutil.copytree(synthetic_dataset / "pan", base / "pan")
    out = variant_set("ldr8", "held_out", tmp_path / "work", frames=8, base=base)
    assert [s.name for s in fmt.find_sequences(out)] == ["pan"]
    first = (out / "pan" / "meta.json").stat().st_mtime_ns
    assert variant_set("ldr8", "held_out", tmp_path / "work", frames=8, base=base) == out
    assert (out / "pan" / "meta.json").stat().st_mtime_ns == first  # unchanged source: kept as it is
    shutil.copytree(synthetic_dataset / "pan_cut", base / "pan_cut")
    variant_set("ldr8", "held_out", tmp_path / "work", frames=8, base=base)
    assert [s.name for s in fmt.find_sequences(out)] == ["pan", "pan_cut"]


def test_results_keyed_by_the_old_variant_name_read_as_today_s():
    from mnss_kit.eval.variant_sets import VARIANTS, current_variant_names

    assert "grid" in VARIANTS and "mnss" not in VARIANTS and VARIANTS["ldr8"][0] == "grid"
    assert list(current_variant_names({"mnss": 1, "halton": 2})) == ["grid", "halton"]
    assert current_variant_names({"mnss": 1, "grid": 3}) == {"grid": 3}  # today's name wins


def test_a_work_directory_rendered_before_the_grid_rename_is_reused(tmp_path):
    from mnss_kit.eval.variant_sets import _render_dir

    assert _render_dir(tmp_path, "grid") == tmp_path / "render_grid"
    (tmp_path / "render_mnss").mkdir()
    assert _render_dir(tmp_path, "grid") == tmp_path / "render_mnss"
    assert _render_dir(tmp_path, "halton") == tmp_path / "render_halton"
    (tmp_path / "render_grid").mkdir()
    assert _render_dir(tmp_path, "grid") == tmp_path / "render_grid"
