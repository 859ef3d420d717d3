"""The frame loop: GPU passes -> NPU graph -> GPU passes, history carried between frames.

A bundle is assembled in memory (:class:`BundleSpec`): GPU weights drawn at random, the MNSS
family's plan (resources and schedule) around them, and the NPU graph of
``test_frame_loop_npu.recon_graph`` at the synthetic dataset's output size.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_frame_loop_npu import recon_files

from mnss_kit.dataset.format import read_meta
from mnss_kit.emulate.bundle import BundleSpec
from mnss_kit.emulate.frame_loop import Emulator
from mnss_kit.model.mnss.config import aa_input_channels
from mnss_kit.emulate.npu_graph import read_npu_graph
from mnss_kit.emulate.run import run_dataset, sequence_frames
from mnss_kit.errors import UserError
from mnss_kit.model.mnss import gpu_plan
from mnss_kit.model.mnss.gpu_stage import GpuStage
from mnss_kit.gpu.weights import Conv3x3
from mnss_kit.model.mnss.gpu_stage import GpuWeights

LR_SIZE = (32, 24)  # tests/conftest.py SYNTHETIC_LR_SIZE


def random_conv(rng, cout, cin) -> Conv3x3:
    return Conv3x3((rng.normal(size=(cout, cin, 3, 3)) * 0.2).astype(np.float32), (rng.normal(size=cout) * 0.1).astype(np.float32))


def make_spec(seed: int = 0, with_history: bool = True) -> BundleSpec:
    rng = np.random.default_rng(seed)
    weights = GpuWeights(random_conv(rng, 1, 4), (random_conv(rng, 8, aa_input_channels(True)), random_conv(rng, 3, 8)))
    stage = GpuStage(scale=2, with_history=with_history, activation="sigmoid", weight_upsample="bilinear",
                     enhance_beta=None, weights=weights)
    tflite, onnx = recon_files(LR_SIZE[1] * 2, LR_SIZE[0] * 2, seed=seed)
    graph = read_npu_graph(tflite)
    (si, zi), (so, zo) = graph.tensors["x"].qparams(), graph.tensors["y"].qparams()
    npu = {"model": "npu.tflite", "input": "x", "output": "y", "input_q": (float(si), zi), "output_q": (float(so), zo)}
    boundary = [{"role": role, "tensor": t, "direction": d, "scale": float(q), "buffer": {"resource": role}}
                for role, t, d, q in (("npu_input", "x", "gpu->npu", si), ("npu_output", "y", "npu->gpu", so))]
    manifest = {"scale": 2, "lr_size": list(LR_SIZE), "golden": {"profile": "tflite-ref"}, "boundary": boundary,
                "resources": gpu_plan.resources(stage, LR_SIZE), "schedule": gpu_plan.schedule(stage, LR_SIZE, npu, "tflite-ref")}
    return BundleSpec("in-memory bundle", graph, tflite, onnx, manifest, dict(gpu_plan.weight_blocks(stage)))


@pytest.fixture(scope="module")
def spec():
    return make_spec()


def frames_of(root, name, count):
    """``count`` recurrent frames of one synthetic sequence, cycling past its end without a reset."""
    seq = root / name
    frames = [f for _, f, _ in sequence_frames(seq, read_meta(seq), None, ["color", "depth", "motion"])]
    out = [dict(frames[i % len(frames)]) for i in range(count)]
    for i, frame in enumerate(out):
        frame["reset"] = i == 0
    return out


def test_litert_and_numpy_npu_backends_agree_over_twelve_recurrent_frames(spec, synthetic_dataset):
    frames = frames_of(synthetic_dataset, "pan", 12)
    emulators = {backend: Emulator(spec, "tflite-ref", backend) for backend in ("numpy", "litert")}
    for t, frame in enumerate(frames):
        results = {b: e.run_frame(frame) for b, e in emulators.items()}
        a, b = results["numpy"], results["litert"]
        assert np.array_equal(a.npu_output, b.npu_output), f"frame {t}: NPU output differs"
        assert np.array_equal(a.display, b.display) and np.array_equal(a.state["history"], b.state["history"]), f"frame {t}"
        assert a.display.shape == (48, 64, 3) and a.display.dtype == np.uint8


def test_history_is_carried_and_reset_clears_it(spec, synthetic_dataset):
    frames = frames_of(synthetic_dataset, "pan", 3)
    emulator = Emulator(spec)
    for frame in frames:
        with_history = emulator.run_frame(frame)
    emulator.reset()
    without = emulator.run_frame(frames[-1])
    assert not np.array_equal(with_history.state["history"], without.state["history"])
    # a reset flag in the frame does the same as reset()
    emulator.run_frame(frames[0])
    flagged = emulator.run_frame(dict(frames[-1], reset=True))
    assert np.array_equal(flagged.state["history"], without.state["history"])


def test_every_named_tensor_in_execution_order(spec, synthetic_dataset):
    frames = frames_of(synthetic_dataset, "pan", 2)
    emulator = Emulator(spec)
    first = emulator.run_frame(frames[0], keep_all=True)
    second = emulator.run_frame(frames[1], keep_all=True)
    npu_names = spec.graph.execution_order()
    gpu_before = ["warped", "warped_depth", "lr_weight", "rectified", "aa_input", "aa_hidden_0", "aa", "npu_input"]
    assert list(second.tensors) == ["color", "depth", "motion", *gpu_before, *npu_names, "history", "display"]
    assert "warped" not in first.tensors  # skipped on a reset frame
    entry = second.entries["head"]
    assert entry.dtype == "int8" and entry.stage == "npu"
    assert (np.float32(entry.scale), entry.zero_point) == spec.graph.tensors["head"].qparams()
    assert second.entries["rectified"].scale is None and second.entries["display"].dtype == "uint8"
    assert np.array_equal(second.tensors["y"], second.npu_output)


def test_run_sequence_writes_outputs_metrics_and_dumps(spec, synthetic_dataset, tmp_path):
    out = tmp_path / "out"
    report = run_dataset(Emulator(spec), synthetic_dataset / "pan_cut", out_dir=out, dump=True, frames=6)
    rows = report["sequences"]["pan_cut"]["frames"]
    assert [r["frame"] for r in rows] == list(range(6))
    assert [r["reset"] for r in rows] == [True, False, False, False, False, True]
    assert all(isinstance(r["psnr_db"], float) for r in rows)
    written = json.loads((out / "metrics.json").read_text())
    assert written["sequences"]["pan_cut"]["summary"]["frames"] == 6
    assert sorted(p.name for p in (out / "pan_cut").glob("*.png")) == [f"frame_{i:05d}.png" for i in range(6)]
    index = json.loads((out / "pan_cut" / "dump" / "index.json").read_text())
    assert [f["index"] for f in index["frames"]] == list(range(6))
    with np.load(out / "pan_cut" / "dump" / "frame_00003.npz") as npz:
        assert npz["head"].dtype == np.int8 and npz["display"].dtype == np.uint8


def test_bad_frames_are_user_errors(spec, synthetic_dataset):
    frame = frames_of(synthetic_dataset, "pan", 1)[0]
    emulator = Emulator(spec)
    with pytest.raises(UserError, match="'color' has shape"):
        emulator.run_frame(dict(frame, color=frame["color"][:-1]))
    with pytest.raises(UserError, match="'depth' holds NaN"):
        emulator.run_frame(dict(frame, depth=np.full_like(frame["depth"], np.nan)))
    with pytest.raises(UserError, match="'motion' is missing"):
        emulator.run_frame({k: v for k, v in frame.items() if k != "motion"})
    with pytest.raises(UserError, match="jitter"):
        emulator.run_frame(dict(frame, jitter=np.array([3.0, 0.0])))


def test_data_of_another_size_is_a_user_error(tmp_path, synthetic_dataset):
    spec = make_spec()
    spec.manifest["lr_size"] = [16, 12]
    with pytest.raises(UserError, match="lr_size"):
        run_dataset(Emulator(spec), synthetic_dataset / "pan")


def test_mesa_gpu_backend_matches_numpy(spec, synthetic_dataset):
    from mnss_kit.gpu import mesa

    try:
        mesa.create_context()
    except UserError as e:
        pytest.skip(str(e))
    frames = frames_of(synthetic_dataset, "pan", 2)
    runs = {}
    for backend in ("numpy", "mesa"):
        emulator = Emulator(spec, gpu_backend=backend)
        runs[backend] = [emulator.run_frame(f) for f in frames]
    for a, b in zip(runs["numpy"], runs["mesa"]):
        assert int(np.max(np.abs(a.npu_output.astype(np.int16) - b.npu_output))) <= 1
        assert int(np.max(np.abs(a.display.astype(np.int16) - b.display))) <= 1
