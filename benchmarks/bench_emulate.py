"""Emulator time per 1280x720 output frame (numpy backends), with a per-stage and per-NPU-op profile.

A bundle of the default model (``mnss_kit.zoo.DEFAULT_MODEL``, ``ntaau_x2``, its shipped weights)
is exported at 1280x720 (calibrated on a small synthetic sequence, golden frame rendered by the
built-in renderer), then a synthetic sequence at 640x360 is run frame after frame through
:class:`mnss_kit.emulate.frame_loop.Emulator` (recurrent state included).  Reported, as medians
over the timed frames (the first frame, a reset, is a warm-up and not timed):

* seconds per frame: total, GPU passes, NPU stage (wall clock), and the process CPU time per
  frame with the load average (on a busy shared machine wall time overstates the work);
* per NPU operator: seconds, and for convolutions the accumulation and requantization split;
* per GPU pass of the bundle's schedule: process CPU seconds per frame (median);
* for every convolution, the requantization by the ``ops.int8.requantize.requantize`` definition versus the
  emulator's :class:`~mnss_kit.emulate.fast.Requantizer` (checked equal on the same accumulators).

    python benchmarks/bench_emulate.py --out benchmarks/results/emulate.json [--profile tflite-ref] [--frames 6] [--workdir DIR]

``--workdir`` keeps the exported bundle and data there and reuses them on the next run (the
export takes half a minute and needs torch).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from mnss_kit.fileio import atomic_write_json
from mnss_kit.zoo import DEFAULT_MODEL

HR_SIZE = (1280, 720)


def make_bundle(root: Path, frames: int) -> tuple[Path, Path]:
    if (root / "bundle" / "manifest.json").is_file() and (root / "data" / "pan").is_dir():  # kept by --workdir
        return root / "bundle", root / "data" / "pan"
    from mnss_kit.cli import main
    from mnss_kit.dataset.synthetic import write_synthetic_sequence

    calibration = root / "calibration"
    write_synthetic_sequence(calibration / "small", lr_size=(64, 36), scale=2, frames=8, name="small")
    data = root / "data"
    write_synthetic_sequence(data / "pan", lr_size=(HR_SIZE[0] // 2, HR_SIZE[1] // 2), scale=2, frames=frames, name="pan")
    bundle = root / "bundle"
    code = main(["export", DEFAULT_MODEL, "--out", str(bundle), "--resolution", f"{HR_SIZE[0]}x{HR_SIZE[1]}",
                 "--data", str(calibration), "--golden-frames", "1", "--no-progress"])
    if code != 0:
        raise SystemExit(f"export failed with status {code}")
    return bundle, data / "pan"


def op_profile(emulator, npu_input: np.ndarray) -> list[dict]:
    """One NPU pass op by op: seconds per op (convolutions split into accumulation and requantization)."""
    from mnss_kit.emulate import fast, kernels
    from mnss_kit.ops.int8.requantize import activation_bounds, requantize

    interp = emulator.npu.interpreter
    graph = interp.graph
    values = {graph.inputs[0]: npu_input}
    rows = []
    for op, names, step in interp.steps:
        inputs = [values[n] if n in values else graph.tensors[n].data for n in names]
        start = time.perf_counter()
        values[op.outputs[0]] = step(inputs)
        row = {"op": op.kind, "output": op.outputs[0], "shape": list(values[op.outputs[0]].shape),
               "seconds": time.perf_counter() - start}
        if op.kind == "CONV_2D":
            x_q = graph.tensors[op.inputs[0]].qparams()
            out = graph.tensors[op.outputs[0]]
            w, b = graph.tensors[op.inputs[1]], graph.tensors[op.inputs[2]]
            t0 = time.perf_counter()
            acc = kernels.conv_accumulators(inputs[0], x_q[1], w.data, b.data, op.options["stride"], op.options["padding"])
            t1 = time.perf_counter()
            scales = np.broadcast_to(w.scale, (w.shape[0],))
            clamp = activation_bounds(op.options["activation"], *out.qparams())
            definition = requantize(acc, x_q[0], scales, *out.qparams(), interp.rt, clamp=clamp)
            t2 = time.perf_counter()
            requantizer = fast.Requantizer(x_q, scales, out.qparams(), op.options["activation"], interp.rt)
            t3 = time.perf_counter()
            fast_result = requantizer(acc.copy(), fast.fits_int32(int(np.prod(w.shape[1:])), b.data))
            t4 = time.perf_counter()
            if not np.array_equal(fast_result, definition):
                raise SystemExit(f"fast requantization differs from the definition at {op.outputs[0]}")
            row.update(accumulate_seconds=t1 - t0, requantize_definition_seconds=t2 - t1, requantize_fast_seconds=t4 - t3)
        rows.append(row)
    return rows


def time_gpu_passes(runner, seconds: dict) -> None:
    """Wrap the schedule runner's GPU step to add each pass's process CPU seconds to ``seconds[pass]``."""
    run_step = runner._gpu

    def timed(step, *args, **kwargs):
        start = time.process_time()
        try:
            return run_step(step, *args, **kwargs)
        finally:
            seconds[step["pass"]] = seconds.get(step["pass"], 0.0) + time.process_time() - start

    runner._gpu = timed


def run_frames(emulator, frames: list[dict]) -> tuple[list[dict], list[float], list[dict], object]:
    """Every frame in order; per timed frame (all but the first): stage seconds, process CPU, GPU pass CPU."""
    timings, cpu, gpu, last = [], [], [], None
    pass_seconds: dict[str, float] = {}
    time_gpu_passes(emulator.runner, pass_seconds)
    for t, frame in enumerate(frames):
        pass_seconds.clear()
        cpu_start = time.process_time()
        result = emulator.run_frame(frame, keep_all=t == len(frames) - 1)
        if t > 0:
            timings.append(result.seconds)
            cpu.append(time.process_time() - cpu_start)
            gpu.append(dict(pass_seconds))
        last = result
    return timings, cpu, gpu, last


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/emulate.json"))
    parser.add_argument("--profile", default="tflite-ref", help="NPU profile (default: tflite-ref)")
    parser.add_argument("--frames", type=int, default=6,
                        help="frames run (at most those of a reused --workdir); the first is a warm-up (default 6)")
    parser.add_argument("--workdir", type=Path, default=None, help="keep (and reuse) the bundle and data here")
    args = parser.parse_args()

    from mnss_kit.dataset.format import read_meta
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.emulate.run import sequence_frames

    load_start = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="mnss-bench-emulate-") as tmp:
        start = time.perf_counter()
        bundle, seq = make_bundle(args.workdir or Path(tmp), args.frames)
        export_seconds = time.perf_counter() - start
        emulator = Emulator(bundle, args.profile, "numpy", "numpy")
        frames = [f for _, f, _ in sequence_frames(seq, read_meta(seq), args.frames, emulator.runner.inputs)]
        timings, cpu, gpu, last = run_frames(emulator, frames)
        ops = op_profile(emulator, last.tensors[emulator.spec.boundary("gpu->npu")["tensor"]])
        n_ops = len(emulator.spec.graph.ops)

    medians = {k: statistics.median(s[k] for s in timings) for k in timings[0]}
    conv = [r for r in ops if "requantize_fast_seconds" in r]
    result = {
        "benchmark": "emulator seconds per 1280x720 output frame (numpy NPU and GPU backends)",
        "model": f"{DEFAULT_MODEL} (the default model, shipped weights)",
        "hr_size": list(HR_SIZE),
        "npu_profile": args.profile,
        "frames_timed": len(timings),
        "median_seconds": medians,
        "median_cpu_seconds_total": statistics.median(cpu),  # all threads; near wall time on a quiet machine
        "median_gpu_pass_cpu_seconds": {k: statistics.median(g.get(k, 0.0) for g in gpu) for k in gpu[0]},
        "load_average_start": list(load_start),  # 1, 5, 15 minutes
        "load_average_end": list(os.getloadavg()),
        "goal_seconds_per_frame": 2.0,
        "meets_goal": medians["total"] < 2.0,
        "npu_ops": n_ops,
        "npu_op_profile": ops,
        "conv_requantize_seconds": {
            "definition_ops_quant": sum(r["requantize_definition_seconds"] for r in conv),
            "fast": sum(r["requantize_fast_seconds"] for r in conv),
            "accumulate": sum(r["accumulate_seconds"] for r in conv),
        },
        "export_seconds": export_seconds,  # near 0 when --workdir held a bundle
        "machine": {"platform": platform.platform(), "processor": platform.processor(), "python": platform.python_version(),
                    "numpy": np.__version__},
        "note": "shared machine: compare numbers from one run only",
    }
    atomic_write_json(args.out, result)
    print(f"median {medians['total']:.3f} s per frame (GPU {medians['gpu']:.3f}, NPU {medians['npu']:.3f}), "
          f"CPU {result['median_cpu_seconds_total']:.3f} s, "
          f"load {load_start[0]:.1f} -> {result['load_average_end'][0]:.1f}; wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
