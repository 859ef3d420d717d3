"""Commands that read a dataset through its decoded cache (``train``, ``data cache``) refuse what
``data check`` calls an error, as the commands reading the files do: a sequence whose motion is absurd
or whose meta.json lists no frames was cached and trained on (or skipped) without a word."""

from __future__ import annotations

import shutil

import pytest
import yaml

from mnss_kit.dataset.check import check_dataset

from fault_helpers import run_cli
from test_checked_reads import FAULTS

TINY_MODEL = {"family": "mnss", "scale": 2, "recon_width": 8, "recon_layers": 2, "aa_width": 4, "aa_layers": 1}


def _train_config(path, data, cache):
    train = {"train_data": str(data), "window": 3, "batch_size": 1, "crop": 12, "epochs": 1, "steps_per_epoch": 2,
             "gt_history_epochs": 0, "bptt": 2, "threads": 1, "log_every": 1, "checkpoint_every": 1, "val_every": 0,
             "cache_dir": str(cache)}
    path.write_text(yaml.safe_dump({"schema": 1, "model": dict(TINY_MODEL), "train": train}))
    return path


COMMANDS = {
    "data cache": lambda data, out: ["data", "cache", data, "--cache-dir", out / "cache"],
    "train": lambda data, out: ["train", _train_config(out.parent / "t.yaml", data, out / "cache"), "--out", out / "run",
                                "--no-progress"],
}


@pytest.mark.parametrize("fault", ["huge_motion", "no_frames"])
@pytest.mark.parametrize("command", COMMANDS)
def test_cached_reads_refuse_what_data_check_refuses(synthetic_dataset, tmp_path, capsys, fault, command):
    shutil.copytree(synthetic_dataset / "pan_cut", tmp_path / "data" / "pan_cut")  # a clean sequence beside it
    seq = shutil.copytree(synthetic_dataset / "pan", tmp_path / "data" / "pan")
    where = FAULTS[fault](seq)
    report = check_dataset(tmp_path / "data", progress=False)
    assert report.errors, "data check must call it an error"
    out = tmp_path / "out"
    code, lines, _ = run_cli(COMMANDS[command](tmp_path / "data", out), capsys)
    assert code == 2, lines
    errors = [line for line in lines if "error:" in line]
    assert len(errors) == 1, lines
    assert f"pan/{where}" in errors[0] and report.errors[0].message in errors[0], errors[0]
    assert not (out / "run" / "model.pt").exists()
