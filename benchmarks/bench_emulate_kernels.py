"""Time the emulator's int8 CONV_2D (and a few other kernels) per runtime; JSON out.

A 3x3 convolution of realistic size for the NPU part of a x2 model at 720p
output (LR 640x360, 32 -> 32 channels) is timed under every runtime, split
into accumulation (im2col + float matmul) and requantization.  Medians over
repeated runs; the machine is shared, so compare numbers from one run only.

    python benchmarks/bench_emulate_kernels.py --out benchmarks/results/emulate_kernels.json
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from mnss_kit.emulate import kernels
from mnss_kit.fileio import atomic_write_json
from mnss_kit.ops.int8.requantize import requantize
from mnss_kit.ops.runtimes import RUNTIMES


def median_seconds(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--height", type=int, default=360)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--channels", type=int, default=32)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/emulate_kernels.json"))
    args = parser.parse_args()

    rng = np.random.default_rng(0)
    c = args.channels
    x = rng.integers(-128, 128, (1, args.height, args.width, c)).astype(np.int8)
    x_q = (np.float32(0.02), 3)
    weights = rng.integers(-127, 128, (c, 3, 3, c)).astype(np.int8)
    dw_weights = rng.integers(-127, 128, (1, 3, 3, c)).astype(np.int8)
    w_scales = np.exp(rng.uniform(-7, -5, c)).astype(np.float32)
    bias = rng.integers(-2000, 2000, c).astype(np.int32)
    out_q = (np.float32(0.05), -4)
    macs = args.height * args.width * c * 9 * c

    acc = kernels.conv_accumulators(x, x_q[1], weights, bias)
    results = {"accumulate_s": median_seconds(lambda: kernels.conv_accumulators(x, x_q[1], weights, bias), args.repeats)}
    per_set = {}
    for name in RUNTIMES:
        conv = median_seconds(lambda: kernels.conv2d(x, x_q, weights, w_scales, bias, out_q, runtime=name), args.repeats)
        dw = median_seconds(lambda: kernels.depthwise_conv2d(x, x_q, dw_weights, w_scales, bias, out_q, runtime=name),
                            args.repeats)
        add = median_seconds(lambda: kernels.add(x, x_q, x, x_q, out_q, runtime=name), args.repeats)
        requant = median_seconds(lambda: requantize(acc, x_q[0], w_scales, out_q[0], out_q[1], name), args.repeats)
        per_set[name] = {"conv2d_s": conv, "requantize_s": requant, "depthwise3x3_s": dw, "add_s": add,
                         "conv2d_gmac_per_s": macs / conv / 1e9}
    report = {
        "benchmark": "emulate_kernels",
        "shape_nhwc": [1, args.height, args.width, c],
        "conv": {"kernel": [3, 3], "out_channels": c, "macs": macs},
        "repeats": args.repeats,
        "statistic": "median",
        "results": results,
        "runtimes": per_set,
        "machine": {"python": platform.python_version(), "numpy": np.__version__, "processor": platform.processor(),
                    "machine": platform.machine()},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_json(args.out, report)
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
