"""A second family, defined only in ``toy_family.py``, through the whole chain by the CLI:
render, train, eval, quantize, split, export, bundle check, emulate (numpy and Mesa GPU backends,
every NPU profile, each bit-exact to its runtime).  Nothing in the package knows it exists: the
test adds it to the family table for its own duration."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from toy_family import TOY_FAMILY

from mnss_kit.cli import main
from mnss_kit.model.families import FAMILIES
from mnss_kit.ops.runtimes import runtime_names

LR_FRAMES = 4


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """The toy family registered, a rendered tiny dataset (HR albedo included) and a trained checkpoint."""
    mp = pytest.MonkeyPatch()
    mp.setitem(FAMILIES, "toy", TOY_FAMILY)
    root = tmp_path_factory.mktemp("toy")
    data = root / "data"
    assert main(["render", "tiny_test", "--out", str(data), "--set", f"frames={LR_FRAMES}", "--no-progress"]) == 0
    config = root / "toy.yaml"
    config.write_text(yaml.safe_dump({"schema": 1, "model": {"family": "toy", "scale": 2, "width": 8, "layers": 2}, "train": {
        "train_data": str(data), "window": 2, "batch_size": 1, "crop": 16, "epochs": 1, "steps_per_epoch": 4,
        "threads": 1, "log_every": 2, "checkpoint_every": 4, "val_every": 0, "cache_dir": str(root / "cache")}}))
    run = root / "run"
    assert main(["train", str(config), "--out", str(run), "--no-progress"]) == 0
    yield {"root": root, "data": data, "ckpt": run / "model.pt", "config": config}
    mp.undo()


def test_train_writes_a_toy_checkpoint(toy):
    from mnss_kit.model.checkpoint import load

    model, record = load(toy["ckpt"])
    assert record["family"] == "toy" and [s for s, _, _ in model.stages()] == ["pack", "net"]
    assert record["macs_per_pixel"] > 0


def test_eval_runs_the_toy_model_against_the_baselines(toy):
    out = toy["root"] / "eval.json"
    assert main(["eval", str(toy["ckpt"]), "--data", str(toy["data"]), "--json", str(out), "--no-progress"]) == 0
    summary = json.loads(out.read_text())
    assert "model" in json.dumps(summary) and "taau" in json.dumps(summary)


def test_split_places_the_npu_stage_on_the_npu(toy, capsys):
    out = toy["root"] / "split.json"
    assert main(["split", str(toy["ckpt"]), "--device", "snapdragon_8_gen_1", "--json", str(out)]) == 0
    placement = json.loads(out.read_text())
    assert {s["name"]: s["placement"] for s in placement["stages"]} == {"pack": "gpu", "net": "npu"}


@pytest.fixture(scope="module")
def bundle(toy):
    quantized = toy["root"] / "int8"
    assert main(["quantize", str(toy["ckpt"]), "--data", str(toy["data"]), "--frames", "4", "--out", str(quantized)]) == 0
    out = toy["root"] / "bundle"
    assert main(["export", str(quantized), "--checkpoint", str(toy["ckpt"]), "--out", str(out), "--data", str(toy["data"]),
                 "--device", "snapdragon_8_gen_1", "--no-progress"]) == 0
    return out


def test_exported_bundle_passes_its_check_and_lists_the_toy_inputs(bundle):
    assert main(["bundle", "check", str(bundle)]) == 0
    manifest = json.loads((bundle / "manifest.json").read_text())
    assert manifest["model"]["family"] == "toy"
    assert [r["name"] for r in manifest["resources"] if r["role"] == "input"] == ["color", "hr_albedo"]
    assert set(manifest["golden"]["frames"][0]["arrays"]) == {"color", "hr_albedo", "npu_input", "npu_output", "display"}


@pytest.mark.parametrize("gpu_backend", ["numpy", "mesa"])
@pytest.mark.parametrize("profile", runtime_names())
def test_emulator_reproduces_the_golden_frames_on_every_profile(bundle, gpu_backend, profile):
    """Golden frames come from the reference passes and LiteRT's reference kernels; every NPU
    profile must give the same int8 NPU input (the GPU pack) and an output within its runtime's
    agreement with the reference (bit-exact for tflite-ref)."""
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.export.reader import open_bundle

    b = open_bundle(bundle)
    backend = "onnxruntime" if profile == "ort-cpu" else "numpy"
    emulator = Emulator(bundle, npu_profile=profile, npu_backend=backend, gpu_backend=gpu_backend)
    for i in range(len(b.manifest["golden"]["frames"])):
        want, frame = b.golden(i), b.golden_inputs(i)
        result = emulator.run_frame(frame, keep_all=True)
        assert np.array_equal(result.tensors["npu_input"], want["npu_input"]), f"frame {i}: npu_input"
        if profile == "tflite-ref":
            assert np.array_equal(result.npu_output, want["npu_output"]), f"frame {i}: npu_output"
            assert np.array_equal(result.display, want["display"]), f"frame {i}: display"


@pytest.mark.parametrize("profile", runtime_names())
def test_numpy_npu_is_bit_exact_to_its_runtime(bundle, toy, profile):
    """The emulator's numpy kernels against the runtime itself, on the toy bundle's real frames."""
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.emulate.sequence import sequence_frames
    from mnss_kit.dataset.format import read_meta

    runtime_backend = "onnxruntime" if profile == "ort-cpu" else "litert"
    numpy_npu = Emulator(bundle, npu_profile=profile, npu_backend="numpy")
    runtime = Emulator(bundle, npu_profile=profile, npu_backend=runtime_backend)
    seq = next(p for p in sorted(Path(toy["data"]).iterdir()) if p.is_dir())
    inputs = numpy_npu.runner.inputs
    compared = 0
    for _, frame, _ in sequence_frames(seq, read_meta(seq), LR_FRAMES, inputs):
        a, b = numpy_npu.run_frame(frame), runtime.run_frame(frame)
        assert np.array_equal(a.npu_output, b.npu_output)
        compared += a.npu_output.size
    assert compared > 0


def test_emulate_cli_runs_a_toy_sequence(bundle, toy, tmp_path):
    out = tmp_path / "emu"
    assert main(["emulate", str(bundle), "--data", str(toy["data"]), "--out", str(out), "--frames", "2", "--no-progress"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert all(s["summary"]["frames"] == 2 for s in metrics["sequences"].values())


def test_java_core_reads_verifies_and_self_tests_the_toy_bundle(bundle, tmp_path):
    """The Android core's bundle and golden contract on the toy family's bundle: hashes verified,
    every field read, the schedule accepted, the self-test over its golden frames passed."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "android"))
    from java_harness import compile_core, missing_tools

    reason = missing_tools()
    if reason:
        pytest.skip(reason)
    java = compile_core(tmp_path / "classes")
    assert java.tool("verify", str(bundle)) == ""
    summary = json.loads(java.tool("read", str(bundle), str(tmp_path / "log")))
    assert summary["schedule_problems"] == [] and summary["golden_inputs"] == ["color", "hr_albedo"]
    report = java.tool("selftest", str(bundle), str(tmp_path / "dump"), "0")
    assert report.strip().endswith("PASSED"), report


def test_app_gl_pipeline_reproduces_the_toy_golden_frames_on_mesa(bundle, tmp_path):
    """The Android app's GL frame pipeline (the phone's classes, through JOGL on Mesa) over the toy
    bundle's golden frames: every GL-produced tensor bit-exact (tests/android/test_gl_pipeline.py)."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "android"))
    from java_harness import compile_gl_pipeline, missing_jogl, run_gl_pipeline

    reason = missing_jogl()
    if reason:
        pytest.skip(reason)
    frames = len(json.loads((bundle / "manifest.json").read_text())["golden"]["frames"])
    tensors, values = run_gl_pipeline(compile_gl_pipeline(tmp_path / "classes"), bundle)
    print(f"GL pipeline on the toy bundle: {tensors} tensors, {values} values compared over {frames} golden frames")
    assert tensors == 2 * frames  # the NPU input buffer and the display, every frame
