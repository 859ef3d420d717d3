"""Checks the ntaau_lr tests at whole and fractional scales share: torch against numpy, and a
bundle's golden frames and int8 graph against the emulator and the runtimes."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch

from mnss_kit.ops import taau_lr


def hwc(x: torch.Tensor) -> np.ndarray:
    """The first image of a batch (N, C, H, W) as a float32 (H, W, C) array."""
    return x[0].permute(1, 2, 0).detach().numpy().astype(np.float32)


def assert_close(got: torch.Tensor, want: np.ndarray, atol: float) -> None:
    np.testing.assert_allclose(hwc(got), want, atol=atol, rtol=0)


class Gathered(NamedTuple):
    inputs: object  # the gathered LR inputs (Gather's): history, history_weight, samples, ...
    trust_lr: torch.Tensor
    features: torch.Tensor  # the NPU input torch made
    want: np.ndarray  # the NPU input ops.taau_lr.steering_features makes of the same history
    change: np.ndarray  # the reference's depth change
    spread: np.ndarray  # the reference's motion spread


def gather_against_reference(model, first: dict, frame: dict) -> Gathered:
    """``model``'s Gather on ``frame`` after ``first`` (so with a reprojected history), and the numpy
    reference of its NPU input for the model's scale, scale input and detail branch."""
    with torch.no_grad():
        _, _, state = model(first)
        state = {k: v for k, v in state.items() if k != "depth"}
        inputs, trust_lr, features = model.lr_gather(frame["color"], frame["depth"], first["depth"], frame["jitter"],
                                                     frame["motion"], torch.zeros(1), state)
    change = taau_lr.depth_change(hwc(frame["depth"]), hwc(first["depth"]), hwc(frame["motion"]))
    spread = taau_lr.motion_spread(hwc(frame["motion"]))
    c = model.config
    want = taau_lr.steering_features(hwc(frame["color"]), hwc(inputs.history), hwc(inputs.history_weight), change, spread,
                                     c.scale, model.params.max_weight, c.scale_input, detail=c.detail)
    return Gathered(inputs, trust_lr, features, want, change, spread)


def assert_golden_frames(bundle_dir, gpu_backend: str, frames: int) -> None:
    """numpy GPU stage: bit for bit over ``frames`` golden frames; Mesa: frame 0's NPU input within
    the golden tolerance (later frames read a history that GPU made)."""
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.export.golden import TOLERANCES
    from mnss_kit.export.reader import open_bundle

    b = open_bundle(bundle_dir)
    emulator = Emulator(bundle_dir, gpu_backend=gpu_backend)
    for i in range(frames if gpu_backend == "numpy" else 1):
        want, result = b.golden(i), emulator.run_frame(b.golden_inputs(i), keep_all=True)
        if gpu_backend == "mesa":
            diff = np.abs(result.tensors["npu_input"].astype(int) - want["npu_input"].astype(int)).max()
            assert diff <= TOLERANCES["npu_input_lsb"]
            continue
        for key, got in (("npu_input", result.tensors["npu_input"]), ("npu_output", result.npu_output),
                         ("display", result.display)):
            assert np.array_equal(got, want[key]), f"frame {i}: {key}"


def npu_differences(bundle_dir, data_dir, profile: str, frames: int) -> tuple[int, int]:
    """``(differing, compared)`` int8 NPU output values of the emulator's numpy kernels against the
    runtime of ``profile`` (LiteRT's kernel set, or ONNX Runtime for ort-cpu) over the first
    ``frames`` frames of the first sequence in ``data_dir``."""
    from mnss_kit.dataset.format import read_meta
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.emulate.run import sequence_frames

    runtime_backend = "onnxruntime" if profile == "ort-cpu" else "litert"
    numpy_npu = Emulator(bundle_dir, npu_profile=profile, npu_backend="numpy")
    runtime = Emulator(bundle_dir, npu_profile=profile, npu_backend=runtime_backend)
    seq = next(p for p in sorted(data_dir.iterdir()) if p.is_dir() and not p.name.startswith("."))
    compared = differing = 0
    for _, frame, _ in sequence_frames(seq, read_meta(seq), frames, numpy_npu.runner.inputs):
        a, b = numpy_npu.run_frame(frame), runtime.run_frame(frame)
        differing += int((a.npu_output != b.npu_output).sum())
        compared += a.npu_output.size
    return differing, compared
