"""``mnss-kit finetune CAPTURE``: tune a model on the first frames of a capture, judge it on the rest."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "fine-tune a model on a capture's first frames and judge it on the held-back rest against the model, TAAU and bicubic"


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got '{text}'") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from .run import DEFAULT_HOLD_BACK, DEFAULT_MINUTES, DEFAULT_WARMUP
    from ..zoo import DEFAULT_MODEL

    parser.add_argument("capture", type=Path, help="a dataset (mnss-kit data import output, or the dataset format)")
    parser.add_argument("--model", default=DEFAULT_MODEL, help=f"the model to start from: a shipped name or a checkpoint (default: {DEFAULT_MODEL})")
    parser.add_argument("--out", type=Path, default=None, help="run directory (default: runs/finetune_<capture name>); rerun to resume")
    parser.add_argument("--minutes", type=_number, default=DEFAULT_MINUTES, help=f"training time budget (default {DEFAULT_MINUTES:g})")
    parser.add_argument("--hold-back", type=_number, default=DEFAULT_HOLD_BACK,
                        help=f"share of each sequence's last frames judged, never trained on (default {DEFAULT_HOLD_BACK:g})")
    parser.add_argument("--warmup", type=int, default=DEFAULT_WARMUP,
                        help=f"frames run before the held-back ones to build up history, not scored (default {DEFAULT_WARMUP})")
    parser.add_argument("--detail", action="store_true",
                        help="ntaau_lr models at an integer scale: after the steering, fit a detail branch that "
                             "sharpens the display (OUT/detail/model.pt; more NPU work and boundary traffic)")
    parser.add_argument("--detail-width", type=int, metavar="N",
                        help="the detail branch's width (default: 24); a narrower one costs less NPU time and "
                             "gains less (docs/training.md)")
    parser.add_argument("--sequences", nargs="+", metavar="NAME", help="only these sequences of the capture")
    parser.add_argument("--threads", type=int, default=0,
                        help="torch threads for the training (default 0: a share of the cores the 1-minute load "
                             "average leaves idle at the start; set it right after another job)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def run(args: argparse.Namespace) -> int:
    from ..errors import UserError
    from ..fileio import check_output
    from .run import finetune

    if args.warmup < 0:
        raise UserError(f"--warmup must be >= 0, got {args.warmup}")
    out = args.out or Path("runs") / f"finetune_{args.capture.resolve().name}"
    check_output(out, "into")
    result = finetune(args.capture, out, args.model, minutes=args.minutes, hold_back=args.hold_back, warmup=args.warmup,
                      sequences=args.sequences, progress=not args.no_progress, detail=args.detail, threads=args.threads,
                      detail_width=args.detail_width)
    print(result.table)
    print(f"wrote {out / 'heldback.json'}, {out / 'heldback.md'} and crops in {out / 'crops'}")
    return 0
