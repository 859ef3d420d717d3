"""``mnss-kit stress --scale S``: bad values and models that cannot run at S are refused in one line
before anything is rendered, the scenarios at 1.5 take Halton jitter where grid has no order, and a
tiny run at 1.5 writes a document and a table that say x1.5."""

from __future__ import annotations

import pytest
import torch
import yaml

from mnss_kit.cli import main
from mnss_kit.fileio import read_json
from mnss_kit.model import checkpoint
from mnss_kit.model.families import build_model, randomise_convs
from mnss_kit.model.ntaau_lr.config import NTAAULRConfig
from mnss_kit.render.config import load_render_config
from mnss_kit.stress.run import rendered_dir, scenario_config
from mnss_kit.stress.scenarios import DATA_CONFIG


def _stress(tmp_path, *extra):
    return main(["stress", "--out", str(tmp_path / "out"), "--work", str(tmp_path / "work"), "--no-progress", *extra])


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    return err


@pytest.mark.parametrize("value, message", [("0.5", "--scale 0.5 is outside"), ("1.0", "--scale 1 is outside"),
                                            ("nan", "finite"), ("9", "--scale 9 is outside")])
def test_bad_scales_are_refused_in_one_line(value, message, tmp_path, capsys):
    assert _stress(tmp_path, "--scale", value) == 2
    assert message in _one_line_error(capsys)
    assert not (tmp_path / "work").exists()


def test_a_model_of_integer_scales_is_refused_at_1_5_before_any_render(tmp_path, capsys):
    assert _stress(tmp_path, "--scale", "1.5", "--models", "mnss_x2") == 2
    err = _one_line_error(capsys)
    assert "model 'mnss_x2': --scale is x1.5, a fractional scale, and the mnss family takes integer scales only" in err
    assert not (tmp_path / "work" / "data").exists()


def test_the_scenarios_at_1_5_take_halton_jitter_and_keep_their_lr_size(tmp_path):
    as_written = {s.name: s for s in load_render_config(DATA_CONFIG).sequences}
    at_1_5 = {s.name: s for s in scenario_config(1.5).sequences}
    assert list(at_1_5) == list(as_written)
    for name, seq in at_1_5.items():
        assert seq.scale == 1.5 and seq.lr_size == as_written[name].lr_size == (160, 90) and seq.hr_size == (240, 135)
        # grid has no order at 1.5; the un-jittered scenario stays un-jittered
        assert seq.jitter == ("center" if as_written[name].jitter == "center" else "halton")
    assert {s.jitter for s in scenario_config(3).sequences} == {"grid", "center"}  # grid exists at x3
    assert scenario_config(2).sequences == load_render_config(DATA_CONFIG).sequences
    assert rendered_dir(tmp_path, 2) == tmp_path / "data" / "stress"  # where x2 renders always were
    assert rendered_dir(tmp_path, 1.5) == tmp_path / "data" / "stress_x1.5"


@pytest.fixture(scope="module")
def tiny_data_at_1_5(tmp_path_factory):
    """fast_objects (the faults' source) rendered at 1.5 on a few LR pixels, and a fresh x2 ntaau_lr
    model (a family that runs at any scale: stress sets it to 1.5)."""
    root = tmp_path_factory.mktemp("stress_x1.5")
    config = root / "tiny_stress.yaml"
    config.write_text(yaml.safe_dump({"version": 1, "sequences": [
        {"name": "fast_objects", "scene": "arena", "seed": 105, "frames": 10, "lr_size": [32, 18], "scale": 1.5,
         "jitter": "halton", "hr_samples": 1}]}))
    assert main(["render", str(config), "--out", str(root / "data"), "--no-progress"]) == 0
    torch.manual_seed(0)
    model = randomise_convs(build_model(NTAAULRConfig(scale=2, width=4, mid_layers=1)), noise=0.5)
    return root / "data", checkpoint.save(root / "tiny_ntaau_lr.pt", model, {"jitter_pattern": "halton"})


def test_a_tiny_run_at_1_5_says_x1_5_and_leaves_out_fsr2(tiny_data_at_1_5, tmp_path, capsys):
    data, model = tiny_data_at_1_5
    assert _stress(tmp_path, "--data", str(data), "--scale", "1.5", "--models", str(model), "--no-crops") == 0
    doc = read_json(tmp_path / "out" / "stress.json")
    assert doc["settings"]["scale"] == 1.5
    assert doc["methods"] == ["tiny_ntaau_lr", "bicubic", "taau"]
    assert "not run at x1.5" in doc["not_covered"]["fsr2"]
    assert doc["scenarios"]["fast_objects"]["jitter_pattern"] == "halton"
    assert set(doc["faults"]) == {"nan_frame", "inf_depth"}
    assert (tmp_path / "out" / "stress.md").read_text().startswith("# Stress scenarios (x1.5)")

    capsys.readouterr()
    assert _stress(tmp_path, "--data", str(data), "--scale", "2", "--models", str(model)) == 2
    assert f"{data}: data is x1.5 but --scale is 2" in _one_line_error(capsys)
