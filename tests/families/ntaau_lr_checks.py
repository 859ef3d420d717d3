"""Checks the ntaau_lr tests at whole and fractional scales share: torch against numpy, and a
bundle's golden frames and int8 graph against the emulator and the runtimes."""

from __future__ import annotations

import numpy as np
import torch


def hwc(x: torch.Tensor) -> np.ndarray:
    """The first image of a batch (N, C, H, W) as a float32 (H, W, C) array."""
    return x[0].permute(1, 2, 0).detach().numpy().astype(np.float32)


def assert_close(got: torch.Tensor, want: np.ndarray, atol: float) -> None:
    np.testing.assert_allclose(hwc(got), want, atol=atol, rtol=0)


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
