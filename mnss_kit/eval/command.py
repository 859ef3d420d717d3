"""``mnss-kit eval``: a model against bicubic and TAAU on full sequences."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "Evaluate a model and baselines on a dataset (PSNR, SSIM, IF-SSIM, temporal error, cut recovery)."

METHOD_NAMES = ("model", "model_nohist", "bicubic", "taau", "fsr2")
DEFAULT_NAMES = ("model", "model_nohist", "bicubic", "taau")  # fsr2 runs only when named
REFERENCES = ("box", "taa", "4x")  # keys of dataset.format.REFERENCE_BUFFERS (not imported: the CLI starts fast)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got '{text}'") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", metavar="MODEL",
                        help="checkpoint path or shipped model name; 'none' evaluates the baselines only")
    parser.add_argument("--data", required=True, metavar="DIR", help="a dataset sequence, or a directory of sequences")
    parser.add_argument("--json", metavar="FILE", help="write the summary JSON here")
    parser.add_argument("--csv", metavar="FILE", help="write per-frame metrics (one row per frame and method) here")
    parser.add_argument("--crops", metavar="DIR", help="write side-by-side PNG crops (worst-error and centre regions) here")
    parser.add_argument("--methods", nargs="+", choices=METHOD_NAMES, metavar="NAME",
                        help=f"methods to run, of {', '.join(METHOD_NAMES)} (default: {', '.join(DEFAULT_NAMES)}; "
                             "without a model: bicubic and taau)")
    parser.add_argument("--reference", choices=REFERENCES, default="box",
                        help="what the metrics compare against: box (hr/reference, the supersampled box filter; default), "
                             "taa (hr/reference_taa, an engine-style native TAA frame) or 4x (hr/reference_4x, 4 rotated-grid samples)")
    parser.add_argument("--scale", metavar="S",
                        help="the scale the data must have: 2, 3, 4 or a quality mode in [1.25, 4] such as 1.5 or 1.7 "
                             "(default: the data's; at a fractional scale the default baselines are those that take it, bicubic)")
    parser.add_argument("--flip", action="store_true", help="also compute FLIP (slower)")
    parser.add_argument("--max-frames", type=_positive_int, metavar="N", help="evaluate at most N frames of each sequence")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..fileio import check_output

    for path, kind in ((args.json, "file"), (args.csv, "file"), (args.crops, "directory")):
        if path:
            check_output(path, kind)

    from .run import evaluate_model
    from .report import format_table, write_csv, write_json

    result = evaluate_model(args.model, args.data, args.methods, max_frames=args.max_frames, flip=args.flip,
                            crops_dir=args.crops, progress=not args.no_progress, reference=args.reference,
                            scale=args.scale)
    if args.csv:
        write_csv(args.csv, result["per_frame"])
    if args.json:
        write_json(args.json, result)
    print(format_table(result))
    return 0
