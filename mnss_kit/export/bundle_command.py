"""``mnss-kit bundle``: inspect an exported bundle (``check`` verifies everything the manifest claims)."""

from __future__ import annotations

import argparse
import sys

HELP = "verify an exported bundle: schema, file hashes, tensor shapes and quantization (manifest vs tflite vs onnx)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="bundle_command", metavar="ACTION", required=True)
    check = sub.add_parser("check", help="verify a bundle; one line per problem, exit 1 if any",
                           description="Verify a bundle: manifest schema and version, SHA-256 of every file, NPU tensor "
                                       "shapes and quantization against npu.tflite and npu_qdq.onnx, weight blocks, golden "
                                       "arrays, schedule references.  Prints one line per problem and exits 1 if there is any.")
    check.add_argument("bundle", metavar="BUNDLE", help="bundle directory (holds manifest.json)")


def run(args: argparse.Namespace) -> int:
    from .check import check_bundle

    problems = check_bundle(args.bundle)
    for line in problems:
        print(line, file=sys.stderr)
    if problems:
        print(f"{args.bundle}: {len(problems)} problem{'s' if len(problems) != 1 else ''}", file=sys.stderr)
        return 1
    print(f"{args.bundle}: ok")
    return 0
