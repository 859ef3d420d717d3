"""Zero-mismatch check of the emulator on a real bundle: numpy kernels vs the matching runtime.

    mnss-kit export mnss_x2 --out runs/mnss_x2_bundle --data data/train_x2 --resolution 640x360
    python scripts/emulator_exactness.py runs/mnss_x2_bundle --data data/test_x2/arena_test --frames 10

For every NPU profile, runs the bundle recurrently twice (numpy NPU backend, and the runtime the
profile reproduces: LiteRT with the matching kernel set, or ONNX Runtime) and counts int8 values
that differ in every tensor both runs expose.  Writes JSON (``--json``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from mnss_kit.dataset.format import read_meta
from mnss_kit.emulate.frame_loop import Emulator
from mnss_kit.emulate.run import sequence_frames
from mnss_kit.ops.runtimes import RUNTIMES


def bundle_frames(bundle: Path, seq: Path, frames: int) -> list[dict]:
    """The first ``frames`` frames of sequence ``seq`` with the inputs ``bundle`` reads."""
    inputs = Emulator(bundle, "tflite-ref", "numpy").runner.inputs
    return [f for _, f, _ in sequence_frames(seq, read_meta(seq), frames, inputs)]


def compare(bundle: Path, frames: list[dict], profile: str) -> dict:
    runtime_backend = RUNTIMES[profile].engine
    emulated, runtime = Emulator(bundle, profile, "numpy"), Emulator(bundle, profile, runtime_backend)
    compared = differing = 0
    for frame in frames:
        a, b = emulated.run_frame(frame, keep_all=True), runtime.run_frame(frame, keep_all=True)
        for name, value in b.tensors.items():
            if value.dtype == np.int8:
                differing += int(np.count_nonzero(a.tensors[name] != value))
                compared += value.size
    return {"runtime": runtime_backend, "frames": len(frames), "int8_values_compared": compared, "int8_values_differing": differing}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("bundle", type=Path)
    parser.add_argument("--data", type=Path, required=True, help="one dataset sequence")
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--json", type=Path, default=Path("benchmarks/results/emulator_exactness.json"))
    args = parser.parse_args()
    frames = bundle_frames(args.bundle, args.data, args.frames)
    results = {}
    for profile in RUNTIMES:
        results[profile] = compare(args.bundle, frames, profile)
        print(profile, results[profile], flush=True)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"bundle": str(args.bundle), "data": str(args.data), "profiles": results}, indent=2) + "\n")


if __name__ == "__main__":
    main()
