"""``mnss-kit quantize``: end to end on the synthetic dataset, and one-line errors for bad input."""

import json
import shutil

import numpy as np
import pytest
import torch

from mnss_kit import cli
from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.fileio import sha256_file
from mnss_kit.model import checkpoint
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model, randomise_convs
from mnss_kit.quantize.run import sample_frames

TINY = dict(scale=2, recon_width=8, recon_layers=3, aa_width=4, aa_layers=1)


@pytest.fixture(scope="module")
def tiny_checkpoint(tmp_path_factory):
    torch.manual_seed(0)
    model = build_model(MNSSConfig(**TINY))
    randomise_convs(model, prefixes=("",))  # a fresh model's last conv is zero: give every layer something to quantize
    return checkpoint.save(tmp_path_factory.mktemp("ckpt") / "tiny.pt", model, {"jitter_pattern": "grid"})


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
    made_from = report["checkpoint"]
    assert made_from["sha256"] == sha256_file(tiny_checkpoint) and made_from["config"]["recon_width"] == TINY["recon_width"]
    assert report["agreement"]["per_op_max_lsb"] <= 1
    for kind in ("fp32", "int8", "delta"):
        assert set(report[kind]) == {"psnr", "ssim", "if_ssim"}
    for key in ("psnr", "ssim", "if_ssim"):
        assert report["delta"][key] == pytest.approx(report["int8"][key] - report["fp32"][key])
    assert report["int8"]["psnr"] != report["fp32"]["psnr"]  # the int8 stage really ran
    assert abs(report["delta"]["psnr"]) < 3.0
    info = report["evaluation"]
    assert info["held_out"] is False and info["data"] == str(synthetic_dataset)
    assert info["int8_runtime"] == "tflite-ref" and info["frames"] == 6 and info["max_frames_per_sequence"] == 3
    assert {s["sequence"] for s in report["sequences"]} == {"pan", "pan_cut"}
    enc = json.loads((out / "encodings.json").read_text())
    assert enc["layout"] == "NHWC" and report["int16"][0] in enc["activation_encodings"]
    assert enc["activation_encodings"][report["int16"][0]]["bitwidth"] == 16
    assert "output PSNR" in stdout and "SQNR dB" in stdout and "delta" in stdout
    text = (out / "report.md").read_text()
    assert "# int8 NPU stage" in text and "not held out" in text


def test_report_uses_the_eval_loop(tiny_checkpoint, synthetic_dataset, tmp_path, capsys):
    """fp32 in report.json is what ``mnss-kit eval`` computes for the model on the same frames."""
    data = tmp_path / "held_out"
    shutil.copytree(synthetic_dataset / "pan", data / "pan")
    out = tmp_path / "int8"
    code, _, stderr = quantize([tiny_checkpoint, "--data", synthetic_dataset, "--eval-data", data, "--out", out,
                                "--frames", 2, "--pipeline-frames", 4, "--eval-runtime", "xnnpack"], capsys)
    assert code == 0, stderr
    report = json.loads((out / "report.json").read_text())
    summary = tmp_path / "eval.json"
    assert cli.main(["eval", str(tiny_checkpoint), "--data", str(data), "--methods", "model", "--max-frames", "4",
                     "--json", str(summary), "--no-progress"]) == 0
    expected = json.loads(summary.read_text())["methods"]["model"]
    for key in ("psnr", "ssim", "if_ssim"):
        assert report["fp32"][key] == pytest.approx(expected[key], abs=1e-9)
    assert report["evaluation"]["held_out"] is True and report["evaluation"]["int8_runtime"] == "xnnpack"
    assert [s["sequence"] for s in report["sequences"]] == ["pan"]


def test_calibration_frames_are_spread_over_sequences():
    assert sample_frames([8, 8], 4) == [[0, 7], [0, 7]]
    assert sample_frames([8, 3], 7) == [[0, 2, 5, 7], [0, 1, 2]]  # a short sequence gives what it has
    assert sample_frames([5], 9) == [[0, 1, 2, 3, 4]]
    assert sum(map(len, sample_frames([64] * 6, 24))) == 24


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
    assert not (tmp_path / "o").exists()


def test_truncated_checkpoint(tiny_checkpoint, tmp_path, capsys):
    cut = tmp_path / "cut.pt"
    data = tiny_checkpoint.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    assert "checkpoint" in error_of([cut, "--out", tmp_path / "o"], capsys)
    assert not (tmp_path / "o").exists()


def test_wrong_scale_data(tiny_checkpoint, tmp_path, capsys):
    write_synthetic_sequence(tmp_path / "x3" / "seq", name="seq", lr_size=(16, 12), scale=3, frames=2)
    msg = error_of([tiny_checkpoint, "--data", tmp_path / "x3", "--out", tmp_path / "o"], capsys)
    assert "x3" in msg and "x2" in msg
    assert not (tmp_path / "o").exists()


def test_wrong_scale_eval_data(tiny_checkpoint, synthetic_dataset, tmp_path, capsys):
    write_synthetic_sequence(tmp_path / "x3" / "seq", name="seq", lr_size=(16, 12), scale=3, frames=2)
    msg = error_of([tiny_checkpoint, "--data", synthetic_dataset, "--eval-data", tmp_path / "x3", "--out", tmp_path / "o"], capsys)
    assert "evaluation" in msg and "x3" in msg and "x2" in msg
    assert not (tmp_path / "o").exists()
    msg = error_of([tiny_checkpoint, "--data", synthetic_dataset, "--eval-data", tmp_path / "missing", "--out", tmp_path / "o"], capsys)
    assert "evaluation data directory not found" in msg
    assert not (tmp_path / "o").exists()


def test_nan_eval_frames(tiny_checkpoint, synthetic_dataset, tmp_path, capsys):
    data = tmp_path / "data"
    shutil.copytree(synthetic_dataset / "pan", data / "pan")
    colour = fmt.read_raw_buffer(data / "pan", "lr", "color", 2)
    colour[3, 4] = np.nan
    fmt.write_buffer(data / "pan", "lr", "color", 2, colour)
    msg = error_of([tiny_checkpoint, "--data", synthetic_dataset, "--eval-data", data, "--out", tmp_path / "o",
                    "--frames", 2, "--pipeline-frames", 4, "--eval-runtime", "xnnpack"], capsys)
    assert "NaN" in msg
    assert not (tmp_path / "o").exists()


def test_contradictory_counts(tiny_checkpoint, tmp_path, capsys):
    assert ">= 0" in error_of([tiny_checkpoint, "--pipeline-frames", -1, "--out", tmp_path / "o"], capsys)
    assert "--pipeline-frames 0" in error_of([tiny_checkpoint, "--eval-data", tmp_path, "--pipeline-frames", 0, "--out", tmp_path / "o"], capsys)
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


def test_shipped_model_files_agree_within_one_lsb_under_xnnpack(synthetic_dataset):
    """The shipped checkpoint's npu.tflite, run by LiteRT's default CPU kernels (XNNPACK), and its
    npu_qdq.onnx in ONNX Runtime: every int8 tensor of the whole graph within 1 LSB.  (LiteRT's
    reference kernels round twice near ties; their whole-graph number is reported, not held to 1.)"""
    from mnss_kit.quantize.run import calibration_samples, open_data
    from mnss_kit.quantize.stage import QuantizeOptions, quantize_module

    model, _ = checkpoint.load("mnss_x2")
    samples = calibration_samples(model, open_data(synthetic_dataset, 2), 6)
    agreement = quantize_module(model.recon, samples, QuantizeOptions()).report["agreement"]
    assert agreement["per_op_max_lsb"] <= 1
    assert agreement["end_to_end_max_lsb_xnnpack"] <= 1, agreement["whole_graph"]
