"""``mnss-kit finetune``: splits a capture in time, tunes within its budget, judges only the held-back
frames against the model it started from and the baselines, resumes, and refuses a short capture."""

from __future__ import annotations

import json

import pytest

from mnss_kit.cli import main
from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.model import checkpoint


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    root = tmp_path_factory.mktemp("capture")
    write_synthetic_sequence(root / "pan", lr_size=(32, 24), frames=24, name="pan")
    return root


def test_a_capture_too_short_to_split_is_refused_in_one_line(tmp_path, capsys):
    write_synthetic_sequence(tmp_path / "cap" / "short", frames=3, name="short")
    assert main(["finetune", str(tmp_path / "cap"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "too short to split" in err[0] and "short" in err[0]
    assert not (tmp_path / "o").exists()


def test_finetune_judges_the_held_back_frames_and_resumes(capture, tmp_path):
    out = tmp_path / "ft"
    args = ["finetune", str(capture), "--out", str(out), "--minutes", "0.02", "--no-progress"]
    assert main(args) == 0
    summary = json.loads((out / "heldback.json").read_text())
    assert summary["settings"]["sequences"]["pan"] == {"frames": 24, "tuned": 14, "held_back": 10}
    assert summary["frames"] == 10 and set(summary["methods"]) >= {"finetuned", "before", "taau", "fsr2", "bicubic"}
    assert all(r["frame"] >= 4 for r in summary["per_frame"])  # warm-up frames are run, not scored
    judged = fmt.read_meta(out / "split" / "judged" / "pan")
    assert judged.frame_count == 14 and judged.frames[0].reset
    assert "| finetuned |" in (out / "heldback.md").read_text() and any((out / "crops").iterdir())
    # a finished run is kept; a cut one (model.pt not yet written) continues from its last.pt
    stamp = (out / "run" / "model.pt").stat().st_mtime_ns
    assert main(args) == 0 and (out / "run" / "model.pt").stat().st_mtime_ns == stamp
    steps = checkpoint.read_record(out / "run" / "model.pt")[0]["training"]["steps"]
    (out / "run" / "model.pt").unlink()
    assert main(args) == 0  # a new run would refuse the directory that holds last.pt
    assert checkpoint.read_record(out / "run" / "model.pt")[0]["training"]["steps"] >= steps


def test_the_budget_not_the_start_models_run_length_ends_a_fine_tune(tmp_path):
    """The shipped default's record says 6000 steps; a fine-tune of it runs until its time budget."""
    from mnss_kit.finetune.run import _experiment

    experiment, record = _experiment("ntaau_lr_x2", tmp_path / "tune", 15.0, 180)
    assert record["train"]["total_steps"] == 6000
    assert experiment.train.total_steps is None and experiment.train.steps >= 1_000_000
    assert experiment.train.time_budget_min == 15.0


def test_threads_reach_the_training_and_a_negative_count_is_refused(tmp_path, capsys, capture):
    from mnss_kit.finetune.run import _experiment

    assert _experiment("ntaau_lr_x2", tmp_path / "tune", 15.0, 180, threads=2)[0].train.threads == 2
    assert _experiment("ntaau_lr_x2", tmp_path / "tune", 15.0, 180)[0].train.threads == 0  # a share of the idle cores
    assert main(["finetune", str(capture), "--out", str(tmp_path / "o"), "--threads", "-1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--threads must be >= 0" in err[0]
    assert not (tmp_path / "o").exists()
