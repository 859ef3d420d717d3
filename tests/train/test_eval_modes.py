"""scripts/eval_modes.py end to end on tiny renders: each set rendered at each mode by ``--scale``
overrides, evaluated with ``mnss-kit eval --scale S``, the JSONs written; a checkpoint that reads
the frame key ``scale`` runs at every mode, one of another family is refused at the other modes."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest
import yaml

from mnss_kit.model.families import FAMILIES
from mnss_kit.train.config import load_experiment
from mnss_kit.train.run import train
from test_mixed_scales import CAMERA, SCALED_FAMILY

REPO = Path(__file__).resolve().parents[2]
# 24x16 at each mode: 36x24 at 1.5, 48x32 at 2 (exact ratios; IF-SSIM needs 22 HR pixels a side)
TINY = """
version: 1
defaults: {lr_size: [24, 16], scale: 2, jitter: grid, hr_samples: 1, frames: 3, start_time: 0.5, camera: cam.yaml}
sequences:
  - {name: arena_modes, scene: arena, seed: 101}
"""


def _script():
    spec = importlib.util.spec_from_file_location("eval_modes", REPO / "scripts" / "eval_modes.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def tiny_config(tmp_path_factory):
    root = tmp_path_factory.mktemp("modes_config")
    (root / "cam.yaml").write_text(CAMERA)
    (root / "tiny_modes.yaml").write_text(TINY)
    return root / "tiny_modes.yaml"


def test_modes_of_the_baselines_render_evaluate_and_write_json(tiny_config, tmp_path):
    script = _script()
    argv = ["none", "--out", str(tmp_path / "out"), "--data-root", str(tmp_path / "data"),
            "--sets", f"{tiny_config}=1.5,2", "--no-progress"]
    assert script.run(argv) == 0
    summary = json.loads((tmp_path / "out" / "modes.json").read_text())
    assert [(e["set"], e["scale"], e["variant"]) for e in summary["entries"]] == [
        ("tiny_modes", 1.5, "jittered"), ("tiny_modes", 2, "jittered"),
        ("tiny_modes", 1.5, "no_jitter_ldr8_depth8"), ("tiny_modes", 2, "no_jitter_ldr8_depth8")]
    for entry in summary["entries"]:
        assert "bicubic" in entry["methods"] and entry["methods"]["bicubic"]["psnr"] > 10
        assert Path(entry["json"]).is_file()
        meta = json.loads(next(Path(entry["data"]).glob("*/meta.json")).read_text())
        assert meta["scale"] == entry["scale"]
        jittered = entry["variant"] == "jittered"
        assert meta["jitter_pattern"] == (("halton" if entry["scale"] == 1.5 else "grid") if jittered else "center")
    assert len({e["json"] for e in summary["entries"]}) == 4, "one eval JSON per mode and variant"
    # a second run reuses the renders and evaluates again
    assert script.run(argv) == 0


def test_default_modes_of_the_held_out_sets():
    script = _script()
    assert script.parse_sets(None) == {"test_x2": (1.3, 1.5, 1.7, 2, 2.5, 3), "unseen_x2": (1.5, 3)}
    assert script.parse_sets(["unseen_x2", "test_x2=1.7"]) == {"unseen_x2": (1.5, 3), "test_x2": (1.7,)}


def test_a_frame_scale_checkpoint_runs_at_every_mode(tiny_config, tmp_path, monkeypatch):
    monkeypatch.setitem(FAMILIES, "scaled", SCALED_FAMILY)
    script = _script()
    data = tmp_path / "data"
    assert script.run(["none", "--out", str(tmp_path / "base"), "--data-root", str(data),
                       "--sets", f"{tiny_config}=1.5,2", "--no-progress", "--max-frames", "2", "--variants", "jittered"]) == 0
    path = tmp_path / "experiment.yaml"
    path.write_text(yaml.safe_dump({"schema": 1, "model": {"family": "scaled", "scale": 2}, "train": {
        "train_data": [str(data / "tiny_modes_x1.5"), str(data / "tiny_modes_x2")], "window": 2, "batch_size": 1,
        "crop": 8, "total_steps": 2, "gt_history_epochs": 0, "threads": 1, "log_every": 1, "val_every": 0,
        "cache_dir": str(tmp_path / "cache")}}))
    ckpt = train(load_experiment(path)[0], tmp_path / "run", progress=False)
    out = tmp_path / "out"
    assert script.run([str(ckpt), "--out", str(out), "--data-root", str(data), "--sets", f"{tiny_config}=1.5,2",
                       "--no-progress", "--max-frames", "2", "--variants", "jittered"]) == 0
    entries = json.loads((out / "modes.json").read_text())["entries"]
    assert [e["scale"] for e in entries] == [1.5, 2] and all("model" in e["methods"] for e in entries)
    result = json.loads((out / "tiny_modes_x1.5.json").read_text())
    assert result["model"]["scale"] == 1.5
    # a 2x-only model beside it at 2x, the floors checked on the page; --resume keeps the JSONs
    assert script.run([str(ckpt), "--out", str(out), "--data-root", str(data), "--sets", f"{tiny_config}=1.5,2",
                       "--no-progress", "--max-frames", "2", "--variants", "jittered", "--compare", "ntaau_lr_x2",
                       "--resume", "--doc", str(tmp_path / "modes.md")]) == 0
    entries = json.loads((out / "modes.json").read_text())["entries"]
    assert "compare" not in entries[0] and entries[1]["compare"]["model"] == "ntaau_lr_x2"
    assert set(entries[1]["sequences"]["arena_modes"]) >= {"model", "taau", "bicubic"}
    page = (tmp_path / "modes.md").read_text()
    assert "## Checks" in page and "against `ntaau_lr_x2` on the same frames" in page
    assert "Trained modes: x1.5, x2" in page
