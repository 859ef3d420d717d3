"""Export beyond the happy path: graph retargeting, atomic output, refused placements, quantize directories."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from mnss_kit.cli import main
from mnss_kit.errors import UserError
from mnss_kit.export.check import check_bundle
from mnss_kit.export.npu_stage import retarget
from mnss_kit.export.run import ExportRequest, export
from mnss_kit.model.checkpoint import load
from mnss_kit.quantize.calibrate import calibrate
from mnss_kit.quantize.params import quantize_graph
from mnss_kit.quantize.tflite_writer import to_tflite
from mnss_kit.quantize.trace import trace


def test_retarget_equals_quantizing_at_the_new_size(tiny_ckpt):
    """Calibrating small and retargeting gives the very file that quantizing at the big size with the same ranges gives."""
    model, _ = load(tiny_ckpt)
    rng = np.random.default_rng(0)
    samples = [[rng.random((1, 3, 16, 24), dtype=np.float32)] for _ in range(3)]
    small = trace(model.recon, [torch.from_numpy(samples[0][0])])
    ranges = calibrate(small, samples, "minmax")
    big = retarget(quantize_graph(small, ranges), model.recon, (40, 32))
    assert big.tensors[big.inputs[0]].shape == (1, 32, 40, 3)
    direct = quantize_graph(trace(model.recon, [torch.zeros(1, 3, 32, 40)]), ranges)
    assert to_tflite(big) == to_tflite(direct)


def test_failed_export_leaves_nothing(tiny_ckpt, synthetic_dataset, tmp_path, monkeypatch):
    import mnss_kit.export.writer as writer

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(writer, "write_golden", broken)
    out = tmp_path / "out"
    request = ExportRequest(model=str(tiny_ckpt), out=out, resolution="64x48", data=synthetic_dataset, progress=False)
    with pytest.raises(RuntimeError, match="disk full"):
        export(request)
    assert list(tmp_path.iterdir()) == []


def test_placement_without_recon_on_the_npu_is_refused(tiny_ckpt, tmp_path):
    request = ExportRequest(model=str(tiny_ckpt), out=tmp_path / "b", resolution="64x48", device="snapdragon_8_gen_1",
                            placement="all-gpu", progress=False)
    with pytest.raises(UserError, match="runs nothing on the NPU"):
        export(request)


def test_user_mistakes_are_one_line_errors(tiny_ckpt, tmp_path, capsys):
    assert main(["export", str(tiny_ckpt), "--out", str(tmp_path / "b"), "--resolution", "65x48"]) == 2
    assert main(["export", str(tmp_path / "none.pt"), "--out", str(tmp_path / "b")]) == 2
    assert main(["export", str(tmp_path), "--out", str(tmp_path / "b")]) == 2  # a directory without npu.tflite
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3 and all(line.startswith("mnss-kit export: error:") for line in lines)
    assert "multiple of the model's scale" in lines[0] and "none.pt" in lines[1] and "quantize directory" in lines[2]


def test_export_from_a_quantize_directory(tiny_ckpt, synthetic_dataset, tmp_path):
    qdir = tmp_path / "q"
    assert main(["quantize", str(tiny_ckpt), "--data", str(synthetic_dataset), "--out", str(qdir), "--frames", "4",
                 "--pipeline-frames", "0", "--no-progress"]) == 0
    out = tmp_path / "bundle"
    assert main(["export", str(qdir), "--checkpoint", str(tiny_ckpt), "--out", str(out), "--data", str(synthetic_dataset),
                 "--profile", "xnnpack", "--golden-frames", "2", "--no-progress"]) == 0
    assert check_bundle(out) == []
    manifest = json.loads((out / "manifest.json").read_text())
    assert (out / "npu.tflite").read_bytes() == (qdir / "npu.tflite").read_bytes()
    assert manifest["npu"]["quantization"]["source"] == "directory"
    assert manifest["golden"]["profile"] == manifest["npu"]["requantization_profile"] == "xnnpack"
    assert manifest["placement"] is None and len(manifest["golden"]["frames"]) == 2


def test_golden_frames_are_rendered_when_no_data_has_the_bundle_size(tiny_ckpt, synthetic_dataset, tmp_path):
    """Calibrated on 64x48 data, exported at 32x24: the graph is retargeted and golden frames rendered (EGL)."""
    out = tmp_path / "bundle"
    manifest = export(ExportRequest(model=str(tiny_ckpt), out=out, resolution="32x24", data=synthetic_dataset, golden_frames=2,
                                    progress=False))
    assert check_bundle(out) == []
    assert manifest["golden"]["source"].startswith("rendered")
    assert manifest["npu"]["quantization"]["calibrated_at_size"] == [64, 48]
    assert manifest["boundary"][0]["shape"] == [1, 24, 32, 3]


def test_command_choices_mirror_their_sources():
    """The CLI lists choices without importing the heavy modules that define them."""
    from mnss_kit.export import command
    from mnss_kit.quantize.run import METHODS

    assert command.METHODS == METHODS


def test_manifest_schema_accepts_the_runtimes_golden_frames_can_use():
    """The schema's profile names are the LiteRT runtimes of ops.runtimes: golden frames run in LiteRT."""
    from mnss_kit.export.manifest import load_schema
    from mnss_kit.ops.runtimes import runtime_names

    assert tuple(load_schema()["$defs"]["profile"]["enum"]) == runtime_names("litert")


def test_a_run_directory_named_like_a_shipped_model_does_not_hide_it(tmp_path, monkeypatch):
    """``mnss-kit export mnss_x2`` next to a training run ``./mnss_x2`` exports the shipped checkpoint,
    as eval and quantize do; a quantize output directory of that name is still taken as one."""
    from mnss_kit.export.run import _sources

    monkeypatch.chdir(tmp_path)
    (tmp_path / "mnss_x2").mkdir()
    assert _sources(ExportRequest(model="mnss_x2", out=tmp_path / "b")) == ("mnss_x2", None, {})
    (tmp_path / "mnss_x2" / "npu.tflite").write_bytes(b"")
    with pytest.raises(UserError, match="quantize directory"):
        _sources(ExportRequest(model="mnss_x2", out=tmp_path / "b"))


def test_a_check_problem_in_the_users_npu_files_is_a_user_error():
    """What fails the bundle check in NPU files copied from a quantize directory names that file;
    any other failure is the writer's own (a bug, with its traceback)."""
    from mnss_kit.export.npu_stage import NpuArtifacts
    from mnss_kit.export.writer import _check_failure

    copied = NpuArtifacts(b"", b"", {"source": "directory", "directory": "q"})
    error = _check_failure(["manifest.json: schedule step 3: bad", "npu_qdq.onnx is corrupt (DecodeError)"], copied)
    assert isinstance(error, UserError) and str(error) == str(Path("q") / "npu_qdq.onnx is corrupt (DecodeError)")
    assert isinstance(_check_failure(["manifest.json: schedule step 3: bad"], copied), RuntimeError)
    quantized_here = NpuArtifacts(b"", b"", {"source": "checkpoint"})
    assert isinstance(_check_failure(["npu.tflite: tensor 'x': not in the file"], quantized_here), RuntimeError)
