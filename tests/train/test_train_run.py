"""End-to-end training runs on the synthetic dataset: learning, checkpoints, stop and resume."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time

import pytest
import torch

from mnss_kit.dataset.cache import dataset_fingerprint
from mnss_kit.errors import UserError
from mnss_kit.model import checkpoint
from mnss_kit.model.families import build_model
from mnss_kit.train.config import load_experiment
from mnss_kit.train.data import open_windows
from mnss_kit.model.mnss.loss import MNSSLoss
from mnss_kit.train.run import train
from mnss_kit.train.recurrent import WindowChunk
from mnss_kit.train.state import LAST

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _held_loss(model, experiment) -> float:
    """Mean loss over every window of the dataset (fixed crops), the model on its own history."""
    cfg = experiment.train
    windows = open_windows(cfg, cfg.train_dirs(), 16, progress=False)
    chunk = WindowChunk(model, MNSSLoss(2))
    with torch.no_grad():
        losses = []
        for i in range(len(windows)):
            batch = {k: v.unsqueeze(0) for k, v in windows[i].items()}
            state = model.initial_state({k: v[:, 0] for k, v in batch.items()})
            losses.append(float(chunk(batch, 0, cfg.window, state, None, False, cfg.window, mask_crop=False)[0]))
    return sum(losses) / len(losses)


def _assert_same_weights(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key in a:
        torch.testing.assert_close(a[key], b[key], rtol=0, atol=0, msg=f"{key} differs")


def test_training_lowers_the_loss(write_experiment, tmp_path):
    experiment, _ = load_experiment(write_experiment(epochs=1, steps_per_epoch=80, gt_history_epochs=0, batch_size=4, crop=16))
    torch.manual_seed(experiment.train.seed)
    before = _held_loss(build_model(experiment.model), experiment)
    final = train(experiment, tmp_path / "run", progress=False)
    model, _ = checkpoint.load(final)
    after = _held_loss(model, experiment)
    assert after < 0.95 * before, (before, after)


def test_checkpoint_is_self_describing(write_experiment, tmp_path, synthetic_dataset):
    experiment, _ = load_experiment(write_experiment())
    final = train(experiment, tmp_path / "run", progress=False)
    model, record = checkpoint.load(final)
    assert record["config"]["recon_width"] == 8 and record["scale"] == 2 and record["jitter_pattern"] == "grid"
    assert record["data_fingerprint"] == dataset_fingerprint(synthetic_dataset)
    assert record["code_version"] and record["train"]["lr"] == 1e-3 and record["train"]["window"] == 3
    summary = record["training"]
    assert summary["steps"] == 12 and summary["stopped"] == "completed" and summary["wall_time_s"] > 0
    assert math.isfinite(summary["final_loss"]) and summary["steps_per_second"] > 0 and summary["world_size"] == 1
    assert (tmp_path / "run" / "logs").is_dir() and any((tmp_path / "run" / "logs").iterdir())
    # last.pt is a model checkpoint too, plus the state to resume
    _, last_record = checkpoint.load(tmp_path / "run" / LAST)
    assert last_record["data_fingerprint"] == record["data_fingerprint"]
    train_state = torch.load(tmp_path / "run" / LAST, weights_only=True)["train_state"]
    assert train_state["step"] == 12 and "optimizer" in train_state and "torch" in train_state["rng"]


def test_stop_by_time_budget_then_resume_matches_an_uninterrupted_run(write_experiment, tmp_path):
    path = write_experiment()
    whole = train(load_experiment(path)[0], tmp_path / "whole", progress=False)
    stopped = train(load_experiment(path, ["train.time_budget_min=1e-6"])[0], tmp_path / "parts", progress=False)
    summary = checkpoint.load(stopped)[1]["training"]
    assert summary["stopped"] == "time_budget" and summary["steps"] == 1
    resumed = train(load_experiment(path)[0], tmp_path / "parts", resume=True, progress=False)
    assert checkpoint.load(resumed)[1]["training"]["steps"] == 12
    _assert_same_weights(checkpoint.read_record(whole)[1], checkpoint.read_record(resumed)[1])


@pytest.mark.slow
def test_resume_after_kill_matches_an_uninterrupted_run(write_experiment, tmp_path):
    """SIGKILL a run after its first checkpoint; --resume must end with the uninterrupted run's weights."""
    path = write_experiment(epochs=1, steps_per_epoch=60, checkpoint_every=4)
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "mnss_kit.train", str(path), "--out", str(out), "--no-progress"]
    proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not (out / LAST).exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not (out / "model.pt").exists(), "the run finished before it could be killed"
    killed_at = torch.load(out / LAST, weights_only=True)["train_state"]["step"]
    assert 0 < killed_at < 60
    resumed = subprocess.run([*cmd, "--resume"], cwd=REPO, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    whole = train(load_experiment(path)[0], tmp_path / "whole", progress=False)
    _assert_same_weights(checkpoint.read_record(whole)[1], checkpoint.read_record(out / "model.pt")[1])


def test_existing_run_needs_resume(write_experiment, tmp_path):
    experiment, _ = load_experiment(write_experiment(total_steps=2))
    train(experiment, tmp_path / "run", progress=False)
    with pytest.raises(UserError, match="--resume"):
        train(experiment, tmp_path / "run", progress=False)
    with pytest.raises(UserError, match="nothing to resume"):
        train(experiment, tmp_path / "other", resume=True, progress=False)
    changed, _ = load_experiment(write_experiment(total_steps=3), ["model.recon_width=4"])
    with pytest.raises(UserError, match="model config differs"):
        train(changed, tmp_path / "run", resume=True, progress=False)


def test_data_of_another_scale_is_refused(write_experiment, tmp_path):
    experiment, _ = load_experiment(write_experiment(), ["model.scale=3"])
    with pytest.raises(UserError, match="x2 but the model is x3"):
        train(experiment, tmp_path / "run", progress=False)
