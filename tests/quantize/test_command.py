"""``mnss-kit quantize``: end to end on the synthetic dataset, and one-line errors for bad input."""

import json
import shutil

import numpy as np
import pytest
import torch

from mnss_kit import cli
from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.model import checkpoint
from mnss_kit.model.config import ModelConfig
from mnss_kit.model.families import build_model

TINY = dict(scale=2, recon_width=8, recon_layers=3, aa_width=4, aa_layers=1)


@pytest.fixture(scope="module")
def tiny_checkpoint(tmp_path_factory):
    torch.manual_seed(0)
    model = build_model(ModelConfig(**TINY))
    with torch.no_grad():  # a fresh model's last conv is zero: give every layer something to quantize
        for p in model.parameters():
            p.add_(torch.randn_like(p) * 0.05)
    return checkpoint.save(tmp_path_factory.mktemp("ckpt") / "tiny.pt", model, {"jitter_pattern": "mnss"})


def quantize(args, capsys):
    code = cli.main(["quantize", *map(str, args), "--no-progress"])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_end_to_end(tiny_checkpoint, synthetic_dataset, tmp_path, capsys):
    out = tmp_path / "int8"
    code, stdout, stderr = quantize(
        [tiny_checkpoint, "--data", synthetic_dataset, "--out", out, "--frames", 6, "--method", "mse", "--a16", 1, "--pipeline-frames", 3], capsys
    )
    assert code == 0, stderr
    assert sorted(p.name for p in out.iterdir()) == ["encodings.json", "npu.tflite", "npu_qdq.onnx", "report.json", "report.md"]
    report = json.loads((out / "report.json").read_text())
    assert report["samples"] == 6 and report["method"] == "mse" and len(report["int16"]) == 1
    assert report["agreement"]["per_op_max_lsb"] <= 1
    assert {p["sequence"] for p in report["pipeline"]} == {"pan", "pan_cut"}
    for p in report["pipeline"]:
        assert abs(p["float_psnr_db"] - p["int8_psnr_db"]) < 3.0
    enc = json.loads((out / "encodings.json").read_text())
    assert enc["layout"] == "NHWC" and report["int16"][0] in enc["activation_encodings"]
    assert enc["activation_encodings"][report["int16"][0]]["bitwidth"] == 16
    assert "output PSNR" in stdout and "SQNR dB" in stdout
    assert "# int8 NPU stage" in (out / "report.md").read_text()


def error_of(args, capsys) -> str:
    code, _, stderr = quantize(args, capsys)
    assert code == 2
    lines = [line for line in stderr.splitlines() if line.startswith("mnss-kit quantize: error:")]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def test_not_a_checkpoint(tmp_path, capsys):
    bad = tmp_path / "model.pt"
    bad.write_bytes(b"not a torch file at all")
    assert "not a readable mnss-kit checkpoint" in error_of([bad, "--out", tmp_path / "o"], capsys)
    other = tmp_path / "other.pt"
    torch.save({"weights": torch.zeros(3)}, other)
    assert "not an mnss-kit checkpoint" in error_of([other, "--out", tmp_path / "o"], capsys)


def test_truncated_checkpoint(tiny_checkpoint, tmp_path, capsys):
    cut = tmp_path / "cut.pt"
    data = tiny_checkpoint.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    assert "checkpoint" in error_of([cut, "--out", tmp_path / "o"], capsys)


def test_wrong_scale_data(tiny_checkpoint, tmp_path, capsys):
    write_synthetic_sequence(tmp_path / "x3" / "seq", name="seq", lr_size=(16, 12), scale=3, frames=2)
    msg = error_of([tiny_checkpoint, "--data", tmp_path / "x3", "--out", tmp_path / "o"], capsys)
    assert "x3" in msg and "x2" in msg
    assert not (tmp_path / "o").exists()


def test_nan_frames(tiny_checkpoint, synthetic_dataset, tmp_path, capsys):
    data = tmp_path / "data"
    shutil.copytree(synthetic_dataset / "pan", data / "pan")
    colour = fmt.read_raw_buffer(data / "pan", "lr", "color", 1)
    colour[3, 4] = np.nan
    fmt.write_buffer(data / "pan", "lr", "color", 1, colour)
    msg = error_of([tiny_checkpoint, "--data", data, "--out", tmp_path / "o"], capsys)
    assert "NaN" in msg
    assert not (tmp_path / "o").exists()


def test_unsupported_op(tiny_checkpoint, synthetic_dataset, tmp_path, capsys, monkeypatch):
    model, record = checkpoint.load(tiny_checkpoint)
    model.recon.body.append(torch.nn.BatchNorm2d(12).eval())
    monkeypatch.setattr(checkpoint, "load", lambda _: (model, record))
    msg = error_of([tiny_checkpoint, "--data", synthetic_dataset, "--out", tmp_path / "o", "--frames", 2], capsys)
    assert "BatchNorm2d" in msg
    assert not (tmp_path / "o").exists()


def test_existing_output_needs_overwrite(tiny_checkpoint, tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    assert "--overwrite" in error_of([tiny_checkpoint, "--out", out], capsys)
    assert (out / "keep.txt").exists()
