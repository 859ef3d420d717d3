"""``mnss-kit train CONFIG``: train a model config into a self-describing checkpoint."""

from __future__ import annotations

import argparse

HELP = "train a model config (a path or a name under mnss_kit/configs/models/) into OUT/model.pt"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", help="experiment config: a YAML path or a name under mnss_kit/configs/models/ (e.g. mnss_x2)")
    parser.add_argument("--out", default=None, help="run directory for last.pt, model.pt and logs/ (default: runs/<config name>)")
    parser.add_argument("--resume", action="store_true", help="continue the run in --out from its last.pt")
    parser.add_argument("--init", default=None, metavar="NAME_OR_CKPT",
                        help="start from the weights of a shipped checkpoint (e.g. mnss_x2) or a .pt file: fine-tuning; "
                        "its family, scale and tensor shapes must match the config's model")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="typed override, e.g. train.lr=5e-4 or model.recon_width=16 (repeatable)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    import os
    from pathlib import Path

    from ..fileio import check_output
    from .config import load_experiment

    experiment, path = load_experiment(args.config, args.overrides)
    out = Path(args.out) if args.out else Path("runs") / path.stem
    for where in (out, experiment.train.log_dir):
        if where:
            check_output(where, "into")
    from .run import train  # imports torch: after the checks

    final = train(experiment, out, resume=args.resume, progress=not args.no_progress, init=args.init)
    if os.environ.get("RANK", "0") == "0":  # one line from a torchrun world too
        print(final)
    return 0
