"""NPU-stage latency, int8 vs fp32, in ONNX Runtime and LiteRT on this CPU; model sizes; JSON out.

The reconstruction stage (``model.recon``) of a model config is traced,
calibrated on random inputs (latency does not depend on the values) and
written as int8 (``npu.tflite``, ``npu_qdq.onnx``) and as fp32 (the float
graph through the same writers).  Each runtime then runs int8 and fp32
interleaved, one call each per round, so both see the same machine load; the
ratio is of the medians of one run.  LiteRT runs with the optimized builtin
kernels and with XNNPACK (AUTO); the reference kernels are far too slow to
time at this size.  The fp32 LiteRT model omits the final clamp, which has
no fused float form (a few thousand cycles at most).

    python bench/bench_quantize.py --out bench/results/quantize.json
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

import numpy as np
import torch

from mnss_kit.fileio import atomic_write_json
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model
from mnss_kit.quantize.calibrate import calibrate
from mnss_kit.quantize.onnx_writer import to_onnx
from mnss_kit.quantize.params import quantize_graph
from mnss_kit.quantize.runtime import FLOAT_GRAPH_OPTIMIZATION, OnnxRunner, TfliteRunner, quantize_inputs
from mnss_kit.quantize.tflite_writer import to_tflite
from mnss_kit.quantize.trace import trace


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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="mnss_x2", help="model config name or path (configs/models)")
    parser.add_argument("--width", type=int, default=1280, help="HR output width")
    parser.add_argument("--height", type=int, default=720, help="HR output height")
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--warmup", type=int, default=2)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("bench/results/quantize.json"))
    args = parser.parse_args()

    torch.manual_seed(0)
    model = build_model(load_model_config(args.model)).eval()
    rng = np.random.default_rng(0)
    samples = [[rng.random((1, 3, args.height, args.width), dtype=np.float32)] for _ in range(2)]
    float_graph = trace(model.recon, [torch.from_numpy(samples[0][0])])
    int8_graph = quantize_graph(float_graph, calibrate(float_graph, samples, "minmax"))

    files = {
        "int8_tflite": to_tflite(int8_graph),
        "fp32_tflite": to_tflite(float_graph),
        "int8_qdq_onnx": to_onnx(int8_graph).SerializeToString(),
        "fp32_onnx": to_onnx(float_graph, quantize=False).SerializeToString(),
    }
    x_float = [np.ascontiguousarray(samples[0][0].transpose(0, 2, 3, 1))]
    x_int8 = quantize_inputs(int8_graph, samples[0])
    runners = {}
    for runtime in ("tflite-builtin", "xnnpack"):
        runners[runtime] = (
            TfliteRunner(files["int8_tflite"], runtime, num_threads=args.threads),
            TfliteRunner(files["fp32_tflite"], runtime, num_threads=args.threads),
        )
    runners["ort-cpu"] = (OnnxRunner(files["int8_qdq_onnx"], num_threads=args.threads), OnnxRunner(files["fp32_onnx"], num_threads=args.threads, level=FLOAT_GRAPH_OPTIMIZATION))

    latency = {}
    for name, (int8_runner, fp32_runner) in runners.items():
        med = interleaved_medians({"int8": lambda r=int8_runner: r.run(x_int8), "fp32": lambda r=fp32_runner: r.run(x_float)}, args.repeats, args.warmup)
        latency[name] = {"int8_ms": med["int8"] * 1e3, "fp32_ms": med["fp32"] * 1e3, "fp32_over_int8": med["fp32"] / med["int8"]}
        print(f"{name:20s} int8 {latency[name]['int8_ms']:8.2f} ms  fp32 {latency[name]['fp32_ms']:8.2f} ms  fp32/int8 {latency[name]['fp32_over_int8']:.2f}")

    result = {
        "benchmark": "quantize",
        "model": args.model,
        "hr_size": [args.width, args.height],
        "threads": args.threads,
        "repeats": args.repeats,
        "ops": len(int8_graph.ops),
        "latency": latency,
        "size_bytes": {k: len(v) for k, v in files.items()},
        "machine": {"platform": platform.platform(), "processor": platform.processor(), "python": platform.python_version()},
        "note": "medians of interleaved runs on a shared machine; compare ratios within one run",
    }
    atomic_write_json(args.out, result)
    print(json.dumps(result["size_bytes"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
