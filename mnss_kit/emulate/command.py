"""``mnss-kit emulate``: run a bundle's frame loop on the desktop, or compare two tensor dumps."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import UserError
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
    parser.add_argument("--scale", metavar="S", help="the upscaling factor the bundle must run at (2, 3, 4 or a quality "
                        "mode such as 1.5 or 1.7, in [1.25, 4]): refused in one line when the bundle is at another")
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
    if args.scale is not None:
        from ..ops.scale import parse_scale

        args.scale = parse_scale(args.scale, "--scale")  # before the bundle is opened: a bad value is one line
    return _emulate(args)


def _emulate(args: argparse.Namespace) -> int:
    import logging

    from .frame_loop import Emulator
    from .run import run_dataset

    profile = args.npu_profile or (runtime_names("onnxruntime")[0] if args.npu_backend == "onnxruntime" else DEFAULT_RUNTIME)
    emulator = Emulator(args.bundle, profile, args.npu_backend, args.gpu_backend)
    if args.scale is not None and float(emulator.spec.scale) != float(args.scale):
        raise UserError(f"{args.bundle}: the bundle is x{emulator.spec.scale:g}, not --scale {args.scale:g}")
    check_golden_sequences(emulator, args.data, args.frames)
    report = run_dataset(emulator, args.data, out_dir=args.out, dump=args.dump, frames=args.frames,
                         overwrite=args.overwrite, progress=not args.no_progress)
    log = logging.getLogger("mnss_kit.emulate")
    for name, seq in report["sequences"].items():
        s = seq["summary"]
        psnr = f", mean PSNR {s['mean_psnr_db']:.2f} dB" if "mean_psnr_db" in s else ""
        log.info("%s: %d frames, median %.3f s per frame%s", name, s["frames"], s.get("median_seconds_total", 0.0), psnr)
    log.info("wrote %s", args.out / "metrics.json")
    return 0


def check_golden_sequences(emulator, data: Path, frames: int | None) -> None:
    """Where ``data`` holds the bundle's own golden sequence, its first frames must come out as the
    golden arrays (within the manifest's tolerances); ``UserError`` before anything is written if not.

    Only with the golden profile: another runtime's rounding may legitimately differ."""
    import logging

    from ..dataset.format import find_sequences, read_meta
    from ..export.golden import golden_mismatch
    from ..export.reader import open_bundle

    spec = emulator.spec
    if emulator.npu_profile != spec.profile:
        logging.getLogger("mnss_kit.emulate").debug("golden frames not compared: they follow %s, not %s",
                                                    spec.profile, emulator.npu_profile)
        return
    bundle = open_bundle(spec.source, verify=False)  # verified when the emulator opened it
    count = min(len(spec.manifest["golden"]["frames"]), frames or 10**9)
    for seq_dir in find_sequences(data):
        if not _is_golden_sequence(bundle, seq_dir, read_meta(seq_dir), emulator, count):
            continue
        emulator.reset()
        for i in range(count):
            emulator.run_frame(bundle.golden_inputs(i))
            want = {k: v for k, v in bundle.golden(i).items() if k not in emulator.runner.inputs}
            got = {k: emulator.runner.values[k] for k in want}
            mismatch = golden_mismatch(spec.manifest, i, got, want)
            if mismatch:
                raise UserError(f"{spec.source}: sequence '{seq_dir.name}' is the bundle's golden sequence, but its frame {i} "
                                f"differs from golden/frame_{i:03d}: {mismatch} beyond the manifest's tolerances")
        emulator.reset()
        logging.getLogger("mnss_kit.emulate").info("%s: frames 0..%d reproduce the bundle's golden frames", seq_dir.name, count - 1)


def _is_golden_sequence(bundle, seq_dir: Path, meta, emulator, count: int) -> bool:
    """The first ``count`` frames of the sequence are the golden inputs (as their textures hold them)."""
    import numpy as np

    from .run import sequence_frames

    if meta.scale != emulator.spec.scale or tuple(meta.lr_size) != emulator.spec.lr_size or meta.frame_count < count:
        return False  # run_dataset refuses or skips it with its own line
    try:
        frames = sequence_frames(seq_dir, meta, count, emulator.runner.inputs)
        for i, (_, frame, _) in enumerate(frames):
            golden = bundle.golden(i)
            entry = bundle.manifest["golden"]["frames"][i]
            if not np.array_equal(np.float32(frame["jitter"]), np.float32(entry["jitter"])):
                return False
            if any(not np.array_equal(frame[k].astype(golden[k].dtype), golden[k]) for k in emulator.runner.inputs):
                return False
    except UserError:
        return False  # a sequence lacking a buffer: run_dataset names it
    return True


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
