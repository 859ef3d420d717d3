"""Renderer throughput: frames per minute for 640x360 -> 1280x720 frames including the 16-spp HR reference.

Renders the first frames of the default data config (all buffers, EXR writes included)
several times into a temporary directory and writes the median to JSON.

    python benchmarks/bench_render.py [--frames 12] [--runs 3] [--out benchmarks/results/render.json]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mnss_kit.fileio import atomic_write_json  # noqa: E402
from mnss_kit.render import gpu  # noqa: E402
from mnss_kit.render.config import load_render_config  # noqa: E402
from mnss_kit.render.renderer import Renderer  # noqa: E402
from mnss_kit.render.scenes import build_scene  # noqa: E402
from mnss_kit.render.run import render_dataset  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default="default", help="data config (first sequence is used)")
    parser.add_argument("--frames", type=int, default=12, help="frames per run")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--out", default="benchmarks/results/render.json")
    args = parser.parse_args()

    cfg = load_render_config(args.config, [f"frames={args.frames}"])
    cfg.sequences = cfg.sequences[:1]
    seq = cfg.sequences[0]
    start = time.perf_counter()  # fixed cost of a run: scene build, shader compile, uploads
    Renderer(build_scene(seq, cfg), tuple(seq.lr_size), seq.scale, seq.hr_samples).release()
    setup = time.perf_counter() - start
    seconds = []
    for _ in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            render_dataset(cfg, tmp, progress=False)
            seconds.append(time.perf_counter() - start)
    median = statistics.median(seconds)
    result = {
        "benchmark": "render",
        "scene": seq.scene,
        "lr_size": list(seq.lr_size),
        "hr_size": list(seq.hr_size),
        "hr_samples": seq.hr_samples,
        "frames_per_run": args.frames,
        "runs_seconds": [round(s, 3) for s in seconds],
        "setup_seconds": round(setup, 3),
        "median_seconds_per_frame": round(median / args.frames, 4),
        "median_frames_per_minute": round(60.0 * args.frames / median, 2),
        "median_seconds_per_frame_after_setup": round((median - setup) / args.frames, 4),
        "estimated_minutes_for_120_frames": round((setup + 120 * (median - setup) / args.frames) / 60.0, 2),
        "note": "includes scene build, GL upload and EXR writes; the machine is shared, so runs vary",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "gl_renderer": gpu.context().info["GL_RENDERER"]},
    }
    atomic_write_json(args.out, result)
    print(f"{result['median_frames_per_minute']} frames/min ({result['median_seconds_per_frame']} s/frame) -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
