"""``mnss-kit emulate``: run a bundle's frame loop on the desktop, or compare two tensor dumps."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..ops.runtimes import DEFAULT_RUNTIME, runtime_names

HELP = "run a bundle on the desktop (bit-exact NPU profiles, GPU passes in numpy or Mesa), or compare tensor dumps"
NPU_BACKENDS = ("numpy", "litert", "onnxruntime")
GPU_BACKENDS = ("numpy", "mesa")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("bundle", nargs="?", type=Path, help="bundle directory (written by `mnss-kit export`)")
    parser.add_argument("--data", type=Path, help="dataset directory or one sequence to run")
    parser.add_argument("--out", type=Path, help="output directory: display PNGs, metrics.json, dumps")
    parser.add_argument("--npu-profile", choices=runtime_names(), default=None,
                        help=f"runtime whose CPU kernels the NPU stage reproduces bit for bit (default: {DEFAULT_RUNTIME}; "
                             f"{', '.join(runtime_names('onnxruntime'))} with --npu-backend onnxruntime)")
    parser.add_argument("--npu-backend", choices=NPU_BACKENDS, default="numpy",
                        help="numpy: interpret npu.tflite op by op; litert / onnxruntime: run the bundle's files there")
    parser.add_argument("--gpu-backend", choices=GPU_BACKENDS, default="numpy",
                        help="numpy: reference passes; mesa: the bundle's shader files through EGL")
    parser.add_argument("--dump", action="store_true", help="write every named tensor of every frame (OUT/<sequence>/dump)")
    parser.add_argument("--frames", type=int, default=None, metavar="N", help="first N frames of each sequence")
    parser.add_argument("--overwrite", action="store_true", help="replace a non-empty --out directory")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("DUMP_A", "DUMP_B"),
                        help="compare two tensor dumps tensor by tensor instead of running a bundle (exit 1 if they differ)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="with --compare: write the per-tensor report as JSON")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..errors import UserError
    from ..fileio import check_output

    for path, kind in ((args.out, "directory"), (args.json, "file")):
        if path:
            check_output(path, kind)
    if args.compare:
        if args.bundle or args.data or args.out:
            raise UserError("--compare takes two dump directories and no bundle, --data or --out")
        return _compare(args)
    if args.json:
        raise UserError("--json goes with --compare")
    missing = [flag for flag, value in (("BUNDLE", args.bundle), ("--data", args.data), ("--out", args.out)) if value is None]
    if missing:
        raise UserError(f"missing {', '.join(missing)} (usage: mnss-kit emulate BUNDLE --data DIR --out DIR)")
    if args.frames is not None and args.frames < 1:
        raise UserError(f"--frames must be at least 1, got {args.frames}")
    return _emulate(args)


def _emulate(args: argparse.Namespace) -> int:
    import logging

    from .frame_loop import Emulator
    from .sequence import run_dataset

    profile = args.npu_profile or (runtime_names("onnxruntime")[0] if args.npu_backend == "onnxruntime" else DEFAULT_RUNTIME)
    emulator = Emulator(args.bundle, profile, args.npu_backend, args.gpu_backend)
    report = run_dataset(emulator, args.data, out_dir=args.out, dump=args.dump, frames=args.frames,
                         overwrite=args.overwrite, progress=not args.no_progress)
    log = logging.getLogger("mnss_kit.emulate")
    for name, seq in report["sequences"].items():
        s = seq["summary"]
        psnr = f", mean PSNR {s['mean_psnr_db']:.2f} dB" if "mean_psnr_db" in s else ""
        log.info("%s: %d frames, median %.3f s per frame%s", name, s["frames"], s.get("median_seconds_total", 0.0), psnr)
    log.info("wrote %s", args.out / "metrics.json")
    return 0


def _compare(args: argparse.Namespace) -> int:
    from ..fileio import atomic_write_json
    from .compare import compare_paths, format_report, verdict

    result, data = compare_paths(*args.compare)
    print(format_report(result))
    if args.json:
        atomic_write_json(args.json, data)
    line = verdict(result, *args.compare)
    if line:
        print(line, file=sys.stderr)
    return 1 if line else 0
