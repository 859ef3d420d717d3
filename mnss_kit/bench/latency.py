"""NPU-stage CPU latency: the int8 graph and its float twin, timed side by side in one run.

The NPU stage of a model (``model.families.npu_module``) is traced at an output size, calibrated
on random inputs (latency does not depend on the values) and written as int8 (``npu.tflite``,
``npu_qdq.onnx``) and as fp32 (the float graph through the same writers).  Each runtime then runs
int8 and fp32 interleaved, one call each per round, so both see the same machine load; the ratio
is of the medians of one run.  LiteRT runs with the optimized builtin kernels and with XNNPACK;
the reference kernels are far too slow to time at real sizes.  ONNX Runtime's int8 is also timed
on its default x86 path (``int8_u8_ms``: QDQ activations rewritten to uint8, the MLAS u8 x s8
kernels), which is faster than the ``ort-cpu`` runtime's int8 x int8 kernels but gives results
that depend on the CPU (``quantize.runtime.ort_session_options``).  The fp32 LiteRT model omits the
final clamp, which has no fused float form (a few thousand cycles at most).
"""

from __future__ import annotations

import statistics
import time

import numpy as np

TIMED_RUNTIMES = ("tflite-builtin", "xnnpack", "ort-cpu")


def interleaved_medians(fns: dict, repeats: int, warmup: int) -> dict[str, float]:
    """Median seconds of each callable, calling them in turn ``repeats`` times after ``warmup`` rounds."""
    times = {k: [] for k in fns}
    for i in range(warmup + repeats):
        for name, fn in fns.items():
            start = time.perf_counter()
            fn()
            if i >= warmup:
                times[name].append(time.perf_counter() - start)
    return {k: statistics.median(v) for k, v in times.items()}


def npu_stage_files(model, hr_size: tuple[int, int], seed: int = 0) -> tuple[dict[str, bytes], object, list]:
    """``(files, int8 graph, samples)``: ``model``'s NPU stage as int8 and fp32 ``.tflite`` and ``.onnx``
    for an ``hr_size`` (w, h) output."""
    import torch

    from ..model.families import npu_input_shapes, npu_module
    from ..quantize.calibrate import calibrate
    from ..quantize.onnx_writer import to_onnx
    from ..quantize.params import quantize_graph
    from ..quantize.tflite_writer import to_tflite
    from ..quantize.trace import trace

    shapes = npu_input_shapes(model, hr_size)
    rng = np.random.default_rng(seed)
    samples = [[rng.random(shape, dtype=np.float32) for shape in shapes] for _ in range(2)]
    module = npu_module(model)
    float_graph = trace(module, [torch.from_numpy(x) for x in samples[0]])
    int8_graph = quantize_graph(float_graph, calibrate(float_graph, samples, "minmax"))
    files = {
        "int8_tflite": to_tflite(int8_graph),
        "fp32_tflite": to_tflite(float_graph),
        "int8_qdq_onnx": to_onnx(int8_graph).SerializeToString(),
        "fp32_onnx": to_onnx(float_graph, quantize=False).SerializeToString(),
    }
    return files, int8_graph, samples


def npu_latency(model, hr_size: tuple[int, int], repeats: int = 10, warmup: int = 2, threads: int = 1) -> dict:
    """``{runtime: {"int8_ms", "fp32_ms", "fp32_over_int8"}}`` for ``model``'s NPU stage at an ``hr_size`` output."""
    from ..quantize.runtime import FLOAT_GRAPH_OPTIMIZATION, OnnxRunner, TfliteRunner, quantize_inputs

    files, int8_graph, samples = npu_stage_files(model, hr_size)
    x_float = [np.ascontiguousarray(x.transpose(0, 2, 3, 1)) for x in samples[0]]
    x_int8 = quantize_inputs(int8_graph, samples[0])
    runners = {runtime: (TfliteRunner(files["int8_tflite"], runtime, num_threads=threads),
                         TfliteRunner(files["fp32_tflite"], runtime, num_threads=threads))
               for runtime in TIMED_RUNTIMES if runtime != "ort-cpu"}
    runners["ort-cpu"] = (OnnxRunner(files["int8_qdq_onnx"], num_threads=threads),
                          OnnxRunner(files["fp32_onnx"], num_threads=threads, level=FLOAT_GRAPH_OPTIMIZATION))
    u8_path = OnnxRunner(files["int8_qdq_onnx"], num_threads=threads, qdq_int8=False)
    latency = {}
    for name, (int8_runner, fp32_runner) in runners.items():
        fns = {"int8": lambda r=int8_runner: r.run(x_int8), "fp32": lambda r=fp32_runner: r.run(x_float)}
        if name == "ort-cpu":
            fns["int8_u8"] = lambda: u8_path.run(x_int8)
        med = interleaved_medians(fns, repeats, warmup)
        latency[name] = {"int8_ms": med["int8"] * 1e3, "fp32_ms": med["fp32"] * 1e3, "fp32_over_int8": med["fp32"] / med["int8"],
                         **({"int8_u8_ms": med["int8_u8"] * 1e3} if "int8_u8" in med else {})}
    return latency
