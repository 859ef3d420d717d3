"""Every family through the whole chain by the CLI: render, train, eval, quantize, split,
export, bundle check, emulate (numpy and Mesa GPU backends, every NPU profile, each bit-exact to
its runtime), the Android core's bundle contract and the app's GL pipeline.

``toy`` is a second family defined only in ``toy_family.py``: nothing in the package knows it
exists (the fixture adds it to the family table for its own duration).  ``fusesr`` is the
shipped reduced FuseSR family: its "l" variant at x4 and its history hybrid at x2, each on a small
render carrying the G-buffers.  ``ntaau`` steers the toolkit's TAAU (exp and tanh: float paths);
``ntaau_lr`` steers it from LR, with an LR depth input and NPU tensors at the LR size."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
import yaml
from toy_family import TOY_FAMILY

from mnss_kit.cli import main
from mnss_kit.export.golden import TOLERANCES
from mnss_kit.model.families import FAMILIES
from mnss_kit.ops.runtimes import runtime_names

LR_FRAMES = 4


@dataclass(frozen=True)
class Case:
    """One family's run through the chain and what its bundle must hold."""

    family: str
    model: dict
    render: tuple[str, ...]  # mnss-kit render overrides of tiny_test
    placements: dict[str, str]
    inputs: tuple[str, ...]  # the bundle's input resources, in manifest order
    register: bool = False  # add to FAMILIES for the test (the toy family is not shipped)
    # GPU passes that are float paths (pow in the display transform): Mesa within the golden
    # tolerances (one int8 step, one display code) instead of bit for bit
    float_gpu: bool = False
    recurrent: bool = False  # the NPU input holds the previous output, so it follows the profile's NPU after frame 0
    gl_tensors: int = field(default=2)  # GL-produced tensors the app compares per golden frame
    shipped: str | None = None  # a shipped checkpoint of this configuration's family, scale and history


CASES = {
    "toy": Case("toy", {"family": "toy", "scale": 2, "width": 8, "layers": 2}, (f"frames={LR_FRAMES}",),
                {"pack": "gpu", "net": "npu"}, ("color", "hr_albedo"), register=True),
    "fusesr": Case("fusesr", {"family": "fusesr", "scale": 4, "variant": "l"},
                   (f"frames={LR_FRAMES}", "scale=4", "jitter=halton", "hr_samples=1", "lr_size=[48,24]"),
                   {"demodulate": "gpu", "encode": "gpu", "unshuffle": "gpu", "backbone": "npu", "remodulate": "gpu"},
                   ("color", "lr_fbeta", "lr_emissive", "hr_fbeta", "hr_normal", "hr_depth", "hr_albedo", "hr_emissive"),
                   float_gpu=True, shipped="fusesr_x4_l"),
    "fusesr_hybrid": Case("fusesr", {"family": "fusesr", "scale": 2, "history": True, "encoder_width": 4, "width": 8,
                                     "hr_channels": 4},
                          (f"frames={LR_FRAMES}", "hr_samples=1", "lr_size=[48,24]"),
                          {"warp_history": "gpu", "demodulate": "gpu", "encode": "gpu", "unshuffle": "gpu", "backbone": "npu",
                           "remodulate": "gpu"},
                          ("color", "lr_fbeta", "lr_emissive", "depth", "motion", "hr_fbeta", "hr_normal", "hr_depth",
                           "hr_albedo", "hr_emissive"), float_gpu=True, recurrent=True, shipped="fusesr_x2_hybrid"),
    "ntaau": Case("ntaau", {"family": "ntaau", "scale": 2, "width": 8, "layers": 2, "filter_bound": 0.25, "box_bound": 1.5,
                            "history_gain_min": 1.0, "still_motion_px": 1.0, "filter_falloff": 1.5},
                  (f"frames={LR_FRAMES}", "hr_samples=1", "lr_size=[48,24]"),
                  {"taau_gather": "gpu", "steer": "npu", "taau_accumulate": "gpu"}, ("color", "motion"),
                  float_gpu=True, recurrent=True, shipped="ntaau_x2"),  # the default model
    "ntaau_lr": Case("ntaau_lr", {"family": "ntaau_lr", "scale": 2, "width": 8, "mid_layers": 1, "filter_bound": 0.25,
                                  "box_bound": 1.5},
                     (f"frames={LR_FRAMES}", "hr_samples=1", "lr_size=[48,24]"),
                     {"lr_gather": "gpu", "steer": "npu", "lr_accumulate": "gpu"}, ("color", "depth", "motion"),
                     float_gpu=True, recurrent=True),
}


@pytest.fixture(scope="module", params=list(CASES))
def chain(request, tmp_path_factory):
    """A family (registered if it is not shipped), a rendered tiny dataset with its G-buffers and a trained checkpoint."""
    case = CASES[request.param]
    mp = pytest.MonkeyPatch()
    if case.register:
        mp.setitem(FAMILIES, "toy", TOY_FAMILY)
    root = tmp_path_factory.mktemp(request.param)
    data = root / "data"
    sets = [a for o in case.render for a in ("--set", o)]
    assert main(["render", "tiny_test", "--out", str(data), *sets, "--no-progress"]) == 0
    config = root / f"{case.family}.yaml"
    config.write_text(yaml.safe_dump({"schema": 1, "model": case.model, "train": {
        "train_data": str(data), "window": 2, "batch_size": 1, "crop": 16, "epochs": 1, "steps_per_epoch": 4,
        "threads": 1, "log_every": 2, "checkpoint_every": 4, "val_every": 0, "cache_dir": str(root / "cache")}}))
    run = root / "run"
    assert main(["train", str(config), "--out", str(run), "--no-progress"]) == 0
    yield {"case": case, "root": root, "data": data, "ckpt": run / "model.pt", "config": config}
    mp.undo()


def test_train_writes_a_checkpoint_of_the_family(chain):
    from mnss_kit.model.checkpoint import load

    model, record = load(chain["ckpt"])
    case = chain["case"]
    assert record["family"] == case.family and [s for s, _, _ in model.stages()] == list(case.placements)
    assert record["macs_per_pixel"] > 0


def test_eval_runs_the_model_against_the_baselines(chain):
    out = chain["root"] / "eval.json"
    assert main(["eval", str(chain["ckpt"]), "--data", str(chain["data"]), "--json", str(out), "--max-frames", "2",
                 "--no-progress"]) == 0
    summary = json.loads(out.read_text())
    assert "model" in json.dumps(summary) and "taau" in json.dumps(summary)


def test_split_places_the_npu_stage_on_the_npu(chain, capsys):
    out = chain["root"] / "split.json"
    assert main(["split", str(chain["ckpt"]), "--device", "snapdragon_8_gen_1", "--json", str(out)]) == 0
    placement = json.loads(out.read_text())
    assert {s["name"]: s["placement"] for s in placement["stages"]} == chain["case"].placements


@pytest.fixture(scope="module")
def bundle(chain):
    quantized = chain["root"] / "int8"
    assert main(["quantize", str(chain["ckpt"]), "--data", str(chain["data"]), "--frames", "4", "--pipeline-frames", "2",
                 "--out", str(quantized)]) == 0
    out = chain["root"] / "bundle"
    assert main(["export", str(quantized), "--checkpoint", str(chain["ckpt"]), "--out", str(out), "--data", str(chain["data"]),
                 "--device", "snapdragon_8_gen_1", "--no-progress"]) == 0
    return out


def test_exported_bundle_passes_its_check_and_lists_the_family_inputs(bundle, chain):
    case = chain["case"]
    assert main(["bundle", "check", str(bundle)]) == 0
    manifest = json.loads((bundle / "manifest.json").read_text())
    assert manifest["model"]["family"] == case.family
    assert [r["name"] for r in manifest["resources"] if r["role"] == "input"] == list(case.inputs)
    assert set(manifest["golden"]["frames"][0]["arrays"]) == {*case.inputs, "npu_input", "npu_output", "display"}


@pytest.mark.parametrize("gpu_backend", ["numpy", "mesa"])
@pytest.mark.parametrize("profile", runtime_names())
def test_emulator_reproduces_the_golden_frames_on_every_profile(bundle, chain, gpu_backend, profile):
    """Golden frames come from the reference passes and LiteRT's reference kernels; every NPU
    profile must give the same int8 NPU input (the GPU pack) and an output within its runtime's
    agreement with the reference (bit-exact for tflite-ref).  A family whose GPU passes are
    float paths gets the golden tolerances on Mesa (``export.golden.TOLERANCES``); one whose NPU
    input holds its previous output is compared after frame 0 only where the NPU is the golden one's."""
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.export.reader import open_bundle

    b = open_bundle(bundle)
    backend = "onnxruntime" if profile == "ort-cpu" else "numpy"
    emulator = Emulator(bundle, npu_profile=profile, npu_backend=backend, gpu_backend=gpu_backend)
    tolerant = gpu_backend == "mesa" and chain["case"].float_gpu
    frames = len(b.manifest["golden"]["frames"])
    if chain["case"].recurrent and (profile != "tflite-ref" or tolerant):
        frames = 1  # later frames read a history this NPU (or this GPU) made
    for i in range(frames):
        want, frame = b.golden(i), b.golden_inputs(i)
        result = emulator.run_frame(frame, keep_all=True)
        if tolerant:  # the NPU then sees other inputs: its output is not compared
            assert _max_diff(result.tensors["npu_input"], want["npu_input"]) <= TOLERANCES["npu_input_lsb"], f"frame {i}"
            continue
        assert np.array_equal(result.tensors["npu_input"], want["npu_input"]), f"frame {i}: npu_input"
        if profile == "tflite-ref":
            assert np.array_equal(result.npu_output, want["npu_output"]), f"frame {i}: npu_output"
            assert np.array_equal(result.display, want["display"]), f"frame {i}: display"


def _max_diff(a: np.ndarray, b: np.ndarray) -> int:
    return int(np.abs(a.astype(np.int32) - b.astype(np.int32)).max())


@pytest.mark.parametrize("profile", runtime_names())
def test_numpy_npu_is_bit_exact_to_its_runtime(bundle, chain, profile):
    """The emulator's numpy kernels against the runtime itself, on the bundle's real frames."""
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.emulate.run import sequence_frames
    from mnss_kit.dataset.format import read_meta

    runtime_backend = "onnxruntime" if profile == "ort-cpu" else "litert"
    numpy_npu = Emulator(bundle, npu_profile=profile, npu_backend="numpy")
    runtime = Emulator(bundle, npu_profile=profile, npu_backend=runtime_backend)
    seq = next(p for p in sorted(Path(chain["data"]).iterdir()) if p.is_dir() and not p.name.startswith("."))
    inputs = numpy_npu.runner.inputs
    compared = 0
    for _, frame, _ in sequence_frames(seq, read_meta(seq), LR_FRAMES, inputs):
        a, b = numpy_npu.run_frame(frame), runtime.run_frame(frame)
        assert np.array_equal(a.npu_output, b.npu_output)
        compared += a.npu_output.size
    assert compared > 0


def test_emulate_cli_runs_a_sequence(bundle, chain, tmp_path):
    out = tmp_path / "emu"
    assert main(["emulate", str(bundle), "--data", str(chain["data"]), "--out", str(out), "--frames", "2", "--no-progress"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert all(s["summary"]["frames"] == 2 for s in metrics["sequences"].values())


def test_the_bundle_is_scored_as_an_eval_method(bundle, chain):
    """``bench.emulated.bundle_method``: the emulated int8 frames scored by the evaluation loop give
    the PSNR the emulator reports for the same frames."""
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.emulate.run import run_dataset
    from mnss_kit.bench.emulated import bundle_method
    from mnss_kit.eval.loop import evaluate

    result = evaluate({"int8": bundle_method(bundle)}, chain["data"], max_frames=2, progress=False)
    report = run_dataset(Emulator(bundle), chain["data"], frames=2)
    for name, entry in result["sequences"].items():
        assert entry["methods"]["int8"]["psnr"] == pytest.approx(report["sequences"][name]["summary"]["mean_psnr_db"], abs=1e-3)


def test_java_core_reads_verifies_and_self_tests_the_bundle(bundle, chain, java_core, tmp_path):
    """The Android core's bundle and golden contract on the family's bundle: hashes verified,
    every field read, the schedule accepted, the self-test over its golden frames passed."""
    assert java_core.tool("verify", str(bundle)) == ""
    summary = json.loads(java_core.tool("read", str(bundle), str(tmp_path / "log")))
    assert summary["schedule_problems"] == [] and summary["golden_inputs"] == list(chain["case"].inputs)
    report = java_core.tool("selftest", str(bundle), str(tmp_path / "dump"), "0")
    assert report.strip().endswith("PASSED"), report


def test_app_gl_pipeline_reproduces_the_golden_frames_on_mesa(bundle, chain, gl_classes):
    """The Android app's GL frame pipeline (the phone's classes, through JOGL on Mesa) over the
    bundle's golden frames: every GL-produced tensor bit-exact, or within one code downstream of a float path
    (pow: fusesr's demodulation; tests/android/test_gl_pipeline.py)."""
    from java_harness import run_gl_pipeline

    frames = len(json.loads((bundle / "manifest.json").read_text())["golden"]["frames"])
    tensors, values = run_gl_pipeline(gl_classes, bundle)
    print(f"GL pipeline on the {chain['case'].family} bundle: {tensors} tensors, {values} values compared over {frames} golden frames")
    assert tensors == chain["case"].gl_tensors * frames  # the NPU input buffer and the display, every frame


def test_a_bundle_of_the_shipped_checkpoint_passes_the_app_checks(chain, java_core, gl_classes, tmp_path):
    """The shipped checkpoint (its trained weights) exported on the case's small render: the Android
    core's verify, read and self-test, then the app's GL pipeline on Mesa."""
    from java_harness import run_gl_pipeline

    from mnss_kit.dataset.format import find_sequences, read_meta

    name = chain["case"].shipped
    if name is None:
        pytest.skip("no shipped checkpoint of this family")

    hr_w, hr_h = read_meta(find_sequences(chain["data"])[0]).hr_size
    bundle = tmp_path / name
    assert main(["export", name, "--out", str(bundle), "--data", str(chain["data"]), "--resolution", f"{hr_w}x{hr_h}",
                 "--no-progress"]) == 0
    assert java_core.tool("verify", str(bundle)) == ""
    assert java_core.tool("selftest", str(bundle), str(tmp_path / "dump"), "0").strip().endswith("PASSED")
    frames = len(json.loads((bundle / "manifest.json").read_text())["golden"]["frames"])
    tensors, values = run_gl_pipeline(gl_classes, bundle)
    assert tensors == chain["case"].gl_tensors * frames and values > 0
