"""``mnss-kit report``: one self-contained HTML page from the bench, stress and size results."""

from __future__ import annotations

import argparse
from pathlib import Path

from .run import DEFAULT_BUDGETS_MS  # a light import: the run module loads matplotlib only to draw

HELP = "one HTML page from the bench, stress and size JSON: a verdict per scale, tables, charts (inline SVG) and crops"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--bench", type=Path, help="bench JSON of `mnss-kit bench` (its charts are drawn from it)")
    parser.add_argument("--stress", type=Path, action="append", metavar="FILE",
                        help="stress JSON of `mnss-kit stress` (its crops/ are read beside it); repeatable, e.g. one "
                             "per scale")
    parser.add_argument("--size", type=Path, action="append", metavar="FILE",
                        help="size.json of `mnss-kit size`; repeatable, one per scene")
    parser.add_argument("--budget-ms", type=float, nargs="+", default=list(DEFAULT_BUDGETS_MS), metavar="MS",
                        help="estimated frame ms budgets of the verdict: the best model within each, per device profile "
                             f"(default: {' '.join(f'{b:g}' for b in DEFAULT_BUDGETS_MS)})")
    parser.add_argument("--out", type=Path, default=Path("runs/report"),
                        help="output directory: index.html, its charts and crops (default: %(default)s, under the "
                             "working directory)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output directory")


def run(args: argparse.Namespace) -> int:
    from ..errors import UserError
    from ..fileio import check_output

    if not args.bench and not args.stress and not args.size:
        raise UserError("give --bench FILE, --stress FILE, --size FILE or several of them")
    if any(not b > 0 for b in args.budget_ms):
        raise UserError(f"--budget-ms must be positive, got {' '.join(f'{b:g}' for b in args.budget_ms)}")
    check_output(args.out, "directory")

    from .run import build_report

    page = build_report(args.bench, args.stress, args.out, overwrite=args.overwrite, sizes=args.size,
                        budgets_ms=tuple(args.budget_ms))
    print(f"wrote {page}")
    return 0
