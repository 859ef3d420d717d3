"""`mnss-kit emulate`: run a bundle on a dataset, dump tensors, compare dumps; user mistakes exit 2."""

from __future__ import annotations

import json

import pytest
from test_frame_loop_bundle import shared_bundle

from mnss_kit.cli import main


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return shared_bundle(tmp_path_factory)


def emulate(root, out, *extra):
    return main(["emulate", str(root / "bundle"), "--data", str(root / "data"), "--out", str(out), "--frames", "4",
                 "--no-progress", *extra])


def test_run_dump_and_compare(root, tmp_path, capsys):
    assert emulate(root, tmp_path / "ref", "--dump") == 0
    metrics = json.loads((tmp_path / "ref" / "metrics.json").read_text())
    rows = metrics["sequences"]["pan"]["frames"]
    assert metrics["npu_profile"] == "tflite-ref" and len(rows) == 4
    assert all(r["psnr_db"] is not None and r["seconds"]["total"] > 0 for r in rows)
    assert len(list((tmp_path / "ref" / "pan").glob("frame_*.png"))) == 4
    assert emulate(root, tmp_path / "opt", "--dump", "--npu-profile", "tflite-builtin") == 0

    capsys.readouterr()
    code = main(["emulate", "--compare", str(tmp_path / "ref" / "pan" / "dump"), str(tmp_path / "opt" / "pan" / "dump"),
                 "--json", str(tmp_path / "cmp.json")])
    report = json.loads((tmp_path / "cmp.json").read_text())
    out = capsys.readouterr().out
    assert code == 1  # the kernel sets differ somewhere
    first = report["first_diverging"]["tensor"]
    assert f">> {first}" in out
    assert report["order"][:3] == ["color", "depth", "motion"] and report["order"][-2:] == ["history", "display"]
    assert report["tensors"][first]["max_lsb"] >= 1
    assert all(report["tensors"][n]["mismatch_fraction"] == 0 for n in report["order"][:3])


def test_dump_matches_the_bundle_golden_frames(root, tmp_path, capsys):
    """The bundle's golden frames (what an on-device self-test compares with) read as a dump."""
    assert emulate(root, tmp_path / "run", "--dump") == 0
    capsys.readouterr()
    code = main(["emulate", "--compare", str(root / "bundle"), str(tmp_path / "run" / "pan" / "dump")])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "no differences" in out


@pytest.mark.parametrize("argv, message", [
    (["emulate"], "missing BUNDLE, --data, --out"),
    (["emulate", "nowhere", "--data", "d", "--out", "o"], "bundle directory not found"),
    (["emulate", "--json", "x.json"], "--json goes with --compare"),
    (["emulate", "--compare", "a", "b"], "dump directory not found: a"),
])
def test_user_mistakes_exit_2_with_one_line(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


def test_onnxruntime_backend_defaults_to_its_profile(root, tmp_path):
    assert emulate(root, tmp_path / "ort", "--npu-backend", "onnxruntime") == 0
    assert json.loads((tmp_path / "ort" / "metrics.json").read_text())["npu_profile"] == "ort-cpu"


def test_profile_of_another_runtime_is_a_user_error(root, tmp_path, capsys):
    assert emulate(root, tmp_path / "x", "--npu-backend", "onnxruntime", "--npu-profile", "xnnpack") == 2
    assert "use --npu-profile ort-cpu" in capsys.readouterr().err


def test_frames_must_be_positive(root, tmp_path, capsys):
    assert emulate(root, tmp_path / "x", "--frames", "0") == 2
    assert "--frames must be at least 1" in capsys.readouterr().err


def test_existing_output_needs_overwrite(root, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    assert emulate(root, out) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert emulate(root, out, "--overwrite") == 0
    assert not (out / "keep.txt").exists()


def test_choices_listed_in_the_command_match_the_emulator():
    from mnss_kit.emulate import command, frame_loop, npu

    assert command.NPU_BACKENDS == npu.BACKENDS and command.GPU_BACKENDS == frame_loop.GPU_BACKENDS
