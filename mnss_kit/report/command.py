"""``mnss-kit report``: one self-contained HTML page from the bench and stress results."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "one HTML page (with its PNGs) from the bench JSON and charts and the stress JSON, plots and crops"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--bench", type=Path, help="bench JSON (its charts are read from charts/ beside it)")
    parser.add_argument("--stress", type=Path, help="stress JSON (its plots/ and crops/ are read beside it)")
    parser.add_argument("--size", type=Path, action="append", metavar="FILE",
                        help="size.json of `mnss-kit size` (its size.png is read beside it); repeatable, one per scene")
    parser.add_argument("--out", type=Path, default=Path("bench/results/report"),
                        help="output directory: index.html and its PNGs (default: %(default)s)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output directory")


def run(args: argparse.Namespace) -> int:
    from ..errors import UserError
    from ..fileio import check_output

    if not args.bench and not args.stress and not args.size:
        raise UserError("give --bench FILE, --stress FILE, --size FILE or several of them")
    check_output(args.out, "directory")

    from .page import build_report

    page = build_report(args.bench, args.stress, args.out, overwrite=args.overwrite, sizes=args.size)
    print(f"wrote {page}")
    return 0
