"""Data that ``data check`` calls wrong is refused by every command that reads it, with data check's
own line; what it warns about, they warn about too."""

from __future__ import annotations

import dataclasses
import logging
import shutil

import numpy as np
import pytest

from mnss_kit.cli import main
from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.check import check_dataset


def _inf_depth(seq):
    meta = fmt.read_meta(seq)
    depth = fmt.read_raw_buffer(seq, "lr", "depth", 2)
    depth[3, 4] = np.inf
    fmt.write_buffer(seq, "lr", "depth", 2, depth)
    return "lr/depth/00002.exr"


def _huge_motion(seq):
    meta = fmt.read_meta(seq)
    fmt.write_buffer(seq, "lr", "motion", 3, np.full((meta.lr_size[1], meta.lr_size[0], 2), 1e9, np.float32))
    return "lr/motion/00003.exr"


def _no_frames(seq):
    fmt.write_meta(seq, fmt.replace_meta(fmt.read_meta(seq), frames=[]))
    return "meta.json"


FAULTS = {"inf_depth": _inf_depth, "huge_motion": _huge_motion, "no_frames": _no_frames}
COMMANDS = {
    "eval": lambda data, out, bundle: ["eval", "none", "--data", str(data), "--no-progress"],
    "data variant": lambda data, out, bundle: ["data", "variant", str(data), "--out", str(out / "v"), "--apply", "ldr8"],
    "finetune": lambda data, out, bundle: ["finetune", str(data), "--out", str(out / "ft"), "--no-progress"],
    "emulate": lambda data, out, bundle: ["emulate", str(bundle), "--data", str(data), "--out", str(out / "e")],
}


@pytest.fixture(scope="module")
def bundle(tmp_path_factory, synthetic_dataset):
    """A tiny x2 model's bundle at the synthetic data's size."""
    import torch

    from mnss_kit.model import checkpoint
    from mnss_kit.model.config import load_model_config
    from mnss_kit.model.families import build_model

    root = tmp_path_factory.mktemp("checked_reads_bundle")
    torch.manual_seed(0)
    ckpt = checkpoint.save(root / "tiny.pt", build_model(load_model_config("mnss_x2_tiny")).eval(), {"jitter_pattern": "grid"})
    assert main(["export", str(ckpt), "--out", str(root / "b"), "--resolution", "64x48", "--data", str(synthetic_dataset),
                 "--golden-frames", "2", "--no-progress"]) == 0
    return root / "b"


@pytest.mark.parametrize("fault", FAULTS)
@pytest.mark.parametrize("command", COMMANDS)
def test_data_data_check_refuses_is_refused_with_its_line(synthetic_dataset, bundle, tmp_path, capsys, fault, command):
    seq = shutil.copytree(synthetic_dataset / "pan", tmp_path / "data" / "pan")
    where = FAULTS[fault](seq)
    report = check_dataset(tmp_path / "data", progress=False)
    assert report.errors, "data check must call it an error"
    capsys.readouterr()
    out = tmp_path / "out"
    assert main(COMMANDS[command](tmp_path / "data", out, bundle)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    assert f"pan/{where}" in err[0] and report.errors[0].message in err[0]
    assert not out.exists() or not any(out.iterdir())


def test_a_one_frame_sequence_is_warned_about(synthetic_dataset, tmp_path):
    seq = shutil.copytree(synthetic_dataset / "pan", tmp_path / "pan")
    meta = fmt.read_meta(seq)
    fmt.write_meta(seq, fmt.replace_meta(meta, frames=meta.frames[:1]))
    report = check_dataset(seq, progress=False)
    assert not report.errors and any("1 frame" in p.message for p in report.warnings)


def test_eval_warns_where_data_check_warns(synthetic_dataset, tmp_path, caplog):
    seq = shutil.copytree(synthetic_dataset / "pan", tmp_path / "pan")
    meta = fmt.read_meta(seq)
    frames = [dataclasses.replace(f, jitter=(-f.jitter[0], -f.jitter[1])) for f in meta.frames]  # not the pattern
    fmt.write_meta(seq, fmt.replace_meta(meta, frames=frames))
    warned = [p.message for p in check_dataset(seq, progress=False).warnings]
    assert warned
    with caplog.at_level(logging.WARNING):
        assert main(["eval", "none", "--data", str(seq), "--no-progress"]) == 0
    assert all(any(w in r.getMessage() for r in caplog.records) for w in warned)


def test_jitter_problems_name_the_frame_with_plain_numbers(synthetic_dataset, tmp_path):
    seq = shutil.copytree(synthetic_dataset / "pan", tmp_path / "pan")
    meta = fmt.read_meta(seq)
    frames = list(meta.frames)
    frames[3] = dataclasses.replace(frames[3], jitter=(0.1, 0.2))  # off the pattern from frame 3
    fmt.write_meta(seq, fmt.replace_meta(meta, frames=frames))
    (warning,) = [p.message for p in check_dataset(seq, progress=False).warnings if "pattern" in p.message]
    assert "from frame 3: (0.1, 0.2)" in warning and "np." not in warning
    frames[1] = dataclasses.replace(frames[1], jitter=(0.123, 0.25))
    fmt.write_meta(seq, fmt.replace_meta(meta, frames=frames))
    text = (seq / "meta.json").read_text()
    (seq / "meta.json").write_text(text.replace("0.123", "NaN", 1))  # as an exporter's JSON writer may put it
    (error,) = [p.message for p in check_dataset(seq, progress=False).errors if "jitter" in p.message]
    assert "frame 1: (nan, 0.25)" in error
