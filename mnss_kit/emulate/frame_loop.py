"""The desktop emulator's frame loop: GPU passes, NPU graph, GPU passes, history carried to the next frame.

    emulator = Emulator("bundle/", npu_profile="tflite-ref", npu_backend="numpy", gpu_backend="numpy")
    outputs = emulator.run_frame({"color": ..., "depth": ..., "motion": ..., "jitter": ..., "reset": False})
    metrics = run_dataset(emulator, "data/corridor_01", out_dir="emulated/")  # emulate.sequence

A frame is numpy: ``color`` (h, w, 3) display values, ``depth`` (h, w, 1) canonical depth,
``motion`` (h, w, 2) LR pixels, ``jitter`` (2,) LR pixels, ``reset`` bool (camera cut).  The GPU
stage is ``mnss_kit.gpu.schedule`` on the numpy reference passes (``gpu.reference``, fp16
storage rounding, run through the bit-identical :mod:`.fast_gpu`) or on Mesa (the bundle's
shader files, :mod:`.bundle_shaders`); the NPU stage is :mod:`.npu`.  Nothing but the bundle is
read: no checkpoint, no torch.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import UserError
from ..gpu import schedule
from .bundle import BundleSpec, read_bundle
from .dump import TensorEntry, entry_for
from .npu import open_npu

GPU_BACKENDS = ("numpy", "mesa")
FRAME_KEYS = {"color": 3, "depth": 1, "motion": 2}  # LR inputs and their channel counts
GPU_INTERMEDIATES = ("warped", "lr_weight", "rectified", "aa")  # before_npu results, in execution order


@dataclass
class FrameResult:
    """One emulated frame.  ``display`` (H, W, 3) uint8 and ``output`` (H, W, 3) float32 (the history,
    fp16 values); ``tensors`` every named tensor in execution order (filled with ``keep_all``) and
    ``entries`` their dtype, shape and quantization; ``seconds`` per stage."""

    display: np.ndarray
    output: np.ndarray
    npu_output: np.ndarray
    tensors: dict[str, np.ndarray]
    entries: dict[str, TensorEntry]
    seconds: dict[str, float]


class Emulator:
    """A bundle run frame by frame on the desktop, recurrent state included."""

    def __init__(self, bundle, npu_profile: str = "tflite-ref", npu_backend: str = "numpy", gpu_backend: str = "numpy"):
        self.spec: BundleSpec = bundle if isinstance(bundle, BundleSpec) else read_bundle(bundle)
        self.npu_profile, self.npu_backend, self.gpu_backend = npu_profile, npu_backend, gpu_backend
        self.npu = open_npu(self.spec.tflite, npu_profile, npu_backend, self.spec.onnx, graph=self.spec.graph)
        self.passes = _gpu_passes(gpu_backend, self.spec)
        self.state: dict | None = None

    def reset(self) -> None:
        """Forget the history: the next frame starts a sequence."""
        self.state = None

    def run_frame(self, inputs: dict, keep_all: bool = False) -> FrameResult:
        """One frame: LR inputs (module docstring) -> display and output; updates the recurrent state."""
        frame = self.check_frame(inputs)
        spec = self.spec
        t0 = time.perf_counter()
        gpu = schedule.before_npu(self.passes, spec.stage, frame, self.state, spec.boundary)
        t1 = time.perf_counter()
        npu = self.npu.run({spec.npu_input: gpu["npu_input"]}, keep_all=keep_all)
        t2 = time.perf_counter()
        history, display = schedule.after_npu(self.passes, spec.stage, npu[spec.npu_output], spec.boundary)
        t3 = time.perf_counter()
        self.state = schedule.next_state(frame, history)
        seconds = {"gpu_before_npu": t1 - t0, "npu": t2 - t1, "gpu_after_npu": t3 - t2, "total": t3 - t0}
        tensors, entries = ({}, {}) if not keep_all else self._named(frame, gpu, npu, history, display)
        return FrameResult(display, history, npu[spec.npu_output], tensors, entries, seconds)

    def check_frame(self, inputs: dict) -> dict:
        """The frame with float32 arrays of the bundle's LR size; ``UserError`` naming a bad key."""
        w, h = self.spec.lr_size
        frame = {}
        for key, channels in FRAME_KEYS.items():
            if key not in inputs:
                raise UserError(f"frame input '{key}' is missing")
            x = np.asarray(inputs[key], dtype=np.float32)
            if x.shape != (h, w, channels):
                raise UserError(f"frame input '{key}' has shape {list(x.shape)}, the bundle expects {[h, w, channels]}")
            if not np.all(np.isfinite(x)):
                raise UserError(f"frame input '{key}' holds NaN or infinite values")
            frame[key] = x
        jitter = np.asarray(inputs.get("jitter", (0.0, 0.0)), dtype=np.float32).reshape(-1)
        if jitter.shape != (2,) or not np.all(np.abs(jitter) <= 0.5):
            raise UserError(f"frame input 'jitter' must be two offsets in [-0.5, 0.5] LR pixels, got {jitter.tolist()}")
        frame["jitter"] = jitter
        frame["reset"] = bool(inputs.get("reset", False))
        return frame

    def _named(self, frame, gpu, npu, history, display) -> tuple[dict, dict]:
        """Every tensor of the frame in execution order, with its dump entry."""
        tensors, entries = {}, {}

        def put(name, array, stage, qparams=None):
            if name in tensors:
                raise UserError(f"tensor name '{name}' is used by both the GPU stage and {self.spec.source}; rename it")
            tensors[name] = array
            entries[name] = entry_for(name, array, qparams, stage)

        put("color", frame["color"].astype(np.float16), "input")  # as the rgba16f input texture holds it
        for key in ("depth", "motion"):
            put(key, frame[key], "input")
        for key in GPU_INTERMEDIATES:
            if gpu.get(key) is not None:
                put(key, gpu[key], "gpu")
        graph = self.spec.graph
        for name in graph.execution_order():
            if name in npu:
                t = graph.tensors[name]
                put(name, npu[name], "npu", t.qparams() if t.quantized and t.scale.size == 1 else None)
        put("history", history, "gpu")
        put("display", display, "gpu")
        return tensors, entries


def _gpu_passes(backend: str, spec: BundleSpec):
    if backend == "numpy":
        from .fast_gpu import FastReferencePasses

        return FastReferencePasses()
    if backend == "mesa":
        from .bundle_shaders import bundle_mesa_passes

        return bundle_mesa_passes(spec)
    raise UserError(f"unknown GPU backend '{backend}' (one of: {', '.join(GPU_BACKENDS)})")
