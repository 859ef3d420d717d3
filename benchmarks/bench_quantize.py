"""NPU-stage latency, int8 vs fp32, in ONNX Runtime and LiteRT on this CPU; model sizes; JSON out.

The measurement is :func:`mnss_kit.bench.latency.npu_latency` (int8 and fp32 timed side by side
in one run) on the NPU stage of a model config with its initial weights.

    python benchmarks/bench_quantize.py --out benchmarks/results/quantize.json
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

import torch

from mnss_kit.bench.latency import npu_latency, npu_stage_files
from mnss_kit.fileio import atomic_write_json
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="mnss_x2", help="model config name or path (mnss_kit/configs/models)")
    parser.add_argument("--width", type=int, default=1280, help="HR output width")
    parser.add_argument("--height", type=int, default=720, help="HR output height")
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--warmup", type=int, default=2)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/quantize.json"))
    args = parser.parse_args()

    torch.manual_seed(0)
    model = build_model(load_model_config(args.model)).eval()
    hr_size = (args.width, args.height)
    latency = npu_latency(model, hr_size, args.repeats, args.warmup, args.threads)
    for name, t in latency.items():
        print(f"{name:20s} int8 {t['int8_ms']:8.2f} ms  fp32 {t['fp32_ms']:8.2f} ms  fp32/int8 {t['fp32_over_int8']:.2f}")
    files, int8_graph, _ = npu_stage_files(model, hr_size)

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
