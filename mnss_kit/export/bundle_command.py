"""``mnss-kit bundle``: inspect an exported bundle (``check`` verifies everything the manifest claims)."""

from __future__ import annotations

import argparse
import sys

HELP = ("verify an exported bundle: schema, internal consistency, file hashes, tensor shapes and quantization "
        "(manifest vs tflite vs onnx); --run replays the golden frames")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="bundle_command", metavar="ACTION", required=True)
    check = sub.add_parser("check", help="verify a bundle; one line per problem, exit 1 if any",
                           description="Verify a bundle: manifest schema and version, sizes, scale and jitter consistent with each "
                                       "other, SHA-256 of every file, NPU tensor "
                                       "shapes and quantization against npu.tflite and npu_qdq.onnx, weight blocks, golden "
                                       "arrays, schedule references.  Prints one line per problem and exits 1 if there is any.")
    check.add_argument("bundle", metavar="BUNDLE", help="bundle directory (holds manifest.json)")
    check.add_argument("--run", action="store_true",
                       help="also replay the golden frames through the bundle's files (refused if they differ beyond the "
                            "manifest's tolerances) and compile every shader on Mesa where EGL exists")


def run(args: argparse.Namespace) -> int:
    from .check import check_bundle

    problems = check_bundle(args.bundle)
    notes = []
    if args.run and not problems:  # replaying a bundle whose files are not what it lists proves nothing
        problems, notes = run_bundle(args.bundle)
    for line in problems:
        print(line, file=sys.stderr)
    if problems:
        print(f"{args.bundle}: {len(problems)} problem{'s' if len(problems) != 1 else ''}", file=sys.stderr)
        return 1
    print(f"{args.bundle}: ok" + (f" ({'; '.join(notes)})" if notes else ""))
    return 0


def run_bundle(bundle: str) -> tuple[list[str], list[str]]:
    """``bundle check --run``: problems and notes of the golden replay and the shader compilation."""
    from pathlib import Path

    from .replay import compile_shaders, replay_golden
    from .manifest import read_manifest

    root = Path(bundle)
    manifest = read_manifest(root)
    problems, compiled = compile_shaders(root, manifest)
    problems += replay_golden(root, manifest)
    frames = len(manifest["golden"]["frames"])
    return problems, [f"{frames} golden frame{'s' if frames != 1 else ''} replayed", compiled]
