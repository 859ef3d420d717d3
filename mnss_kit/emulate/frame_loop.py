"""The desktop emulator's frame loop: the bundle's schedule, step by step, recurrent resources kept.

    emulator = Emulator("bundle/", npu_profile="tflite-ref", npu_backend="numpy", gpu_backend="numpy")
    outputs = emulator.run_frame({"color": ..., "depth": ..., "motion": ..., "jitter": ..., "reset": False})
    metrics = run_dataset(emulator, "data/corridor_01", out_dir="emulated/")  # emulate.run

A frame is numpy: every ``input`` resource of the manifest (``(h, w, C)`` float32 at its size;
for MNSS ``color`` display values, ``depth`` canonical depth, ``motion`` LR pixels), ``jitter``
(2,) LR pixels and ``reset`` bool (camera cut).  The schedule runs through
:class:`mnss_kit.gpu.interpret.ScheduleRunner`: GPU steps on the numpy reference passes
(``gpu.reference``, fp16 storage rounding, run through the bit-identical :mod:`.fast_gpu`) or on
Mesa (the bundle's shader files, :mod:`.bundle_shaders`), NPU steps on :mod:`.npu`.  Nothing but
the bundle is read: no checkpoint, no torch.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import UserError
from ..export.golden import FORMAT_DTYPES
from ..gpu.interpret import ScheduleRunner
from .bundle import BundleSpec, read_bundle
from .dump import TensorEntry, entry_for
from .npu import open_npu

GPU_BACKENDS = ("numpy", "mesa")


@dataclass
class FrameResult:
    """One emulated frame.  ``display`` (H, W, 3) uint8 (the ``output`` resource); ``npu_output`` what
    the NPU returned to the GPU; ``state`` the ``state`` resources after the frame (for MNSS
    ``history`` (H, W, 3), fp16 values); ``tensors`` every named tensor in execution order (filled
    with ``keep_all``) and ``entries`` their dtype, shape and quantization; ``seconds`` per stage."""

    display: np.ndarray
    npu_output: np.ndarray
    state: dict[str, np.ndarray]
    tensors: dict[str, np.ndarray]
    entries: dict[str, TensorEntry]
    seconds: dict[str, float]


class Emulator:
    """A bundle run frame by frame on the desktop, recurrent state included."""

    def __init__(self, bundle, npu_profile: str = "tflite-ref", npu_backend: str = "numpy", gpu_backend: str = "numpy"):
        self.spec: BundleSpec = bundle if isinstance(bundle, BundleSpec) else read_bundle(bundle)
        self.npu_profile, self.npu_backend, self.gpu_backend = npu_profile, npu_backend, gpu_backend
        self.npu = open_npu(self.spec.tflite, npu_profile, npu_backend, self.spec.onnx, graph=self.spec.graph)
        m = self.spec.manifest
        self.runner = ScheduleRunner(m["resources"], m["schedule"], self.spec.weights, _gpu_passes(gpu_backend, self.spec),
                                     self._run_npu, self.spec.profile, self.spec.scale)
        self._keep_all, self._npu_tensors, self._npu_seconds = False, {}, 0.0

    def reset(self) -> None:
        """Forget the history: the next frame starts a sequence."""
        self.runner.reset()

    def _run_npu(self, step: dict, feeds: dict) -> dict:
        t0 = time.perf_counter()
        self._npu_tensors = self.npu.run(feeds, keep_all=self._keep_all)
        self._npu_seconds += time.perf_counter() - t0
        return self._npu_tensors

    def run_frame(self, inputs: dict, keep_all: bool = False) -> FrameResult:
        """One frame: inputs (module docstring) -> display and state; updates the recurrent state."""
        frame = self.check_frame(inputs)
        self._keep_all, self._npu_seconds = keep_all, 0.0
        t0 = time.perf_counter()
        steps = self.runner.run_frame({k: frame[k] for k in self.runner.inputs}, frame["jitter"], frame["reset"])
        total = time.perf_counter() - t0
        values = self.runner.values
        spec = self.spec
        npu_output = values[spec.boundary("npu->gpu")["buffer"]["resource"]]
        display = values[spec.resources("output")[0]["name"]]
        state = {r["name"]: values.get(r["name"]) for r in spec.resources("state")}
        seconds = {"gpu": total - self._npu_seconds, "npu": self._npu_seconds, "total": total}
        tensors, entries = ({}, {}) if not keep_all else self._named(frame, steps)
        return FrameResult(display, npu_output, state, tensors, entries, seconds)

    def check_frame(self, inputs: dict) -> dict:
        """The frame with float32 arrays of the bundle's sizes; ``UserError`` naming a bad key."""
        frame = {}
        for resource in self.spec.resources("input"):
            key, (w, h), channels = resource["name"], resource["size"], resource["channels"]
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

    def _named(self, frame: dict, steps) -> tuple[dict, dict]:
        """Every tensor of the frame in execution order (inputs as their textures hold them, what
        each GPU step wrote, every NPU tensor), with its dump entry."""
        tensors, entries = {}, {}
        formats = {r["name"]: r.get("format") for r in self.spec.manifest["resources"]}

        def put(name, array, stage, qparams=None):
            if name in tensors and stage != "gpu":
                raise UserError(f"tensor name '{name}' is used by both the GPU stage and {self.spec.source}; rename it")
            tensors[name] = array
            entries[name] = entry_for(name, array, qparams, stage)

        for key in self.runner.inputs:
            put(key, frame[key].astype(FORMAT_DTYPES[formats[key]]), "input")  # as the input texture holds it
        graph = self.spec.graph
        for result in steps:
            if result.step["kind"] == "gpu":
                for name, array in result.written.items():
                    put(name, array, "gpu")
                continue
            for name in graph.execution_order():
                if name in self._npu_tensors:
                    t = graph.tensors[name]
                    put(name, self._npu_tensors[name], "npu", t.qparams() if t.quantized and t.scale.size == 1 else None)
        return tensors, entries



def _gpu_passes(backend: str, spec: BundleSpec):
    if backend == "numpy":
        from .fast_gpu import FastReferencePasses

        return FastReferencePasses()
    if backend == "mesa":
        from .bundle_shaders import bundle_mesa_passes

        return bundle_mesa_passes(spec)
    raise UserError(f"unknown GPU backend '{backend}' (one of: {', '.join(GPU_BACKENDS)})")
