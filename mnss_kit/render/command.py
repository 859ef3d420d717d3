"""``mnss-kit render``: render a data config into dataset sequences."""

from __future__ import annotations

import argparse

HELP = "render built-in or imported scenes into LR/HR dataset sequences (OpenGL through EGL)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", nargs="?", default="default",
                        help="data config: a YAML path or a name under mnss_kit/configs/data/ (default: default)")
    parser.add_argument("--out", required=True, help="output directory; one sub-directory per sequence")
    parser.add_argument("--shard", default=None, metavar="I/N",
                        help="render only shard I of N (disjoint frame sets; outputs merge by copying)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override a sequence key in every sequence (frames=8) or in one (NAME.frames=8); "
                             "jitter=grid, halton or center (mnss, the old name of grid, is still read)")
    parser.add_argument("--scale", metavar="S",
                        help="the scale of every sequence (--set scale=S): 2, 3, 4 or a quality mode in [1.25, 4] "
                             "such as 1.5 or 1.7; with hr_size in the config the LR size is round(hr_size / S)")
    parser.add_argument("--overwrite", action="store_true", help="re-render frames that already exist")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..fileio import check_output
    from .config import load_render_config
    from .run import parse_shard, render_dataset

    check_output(args.out, "into")
    shard = parse_shard(args.shard)
    overrides = list(args.overrides)
    if getattr(args, "scale", None) is not None:
        from ..ops.scale import parse_scale

        overrides.insert(0, f"scale={parse_scale(args.scale, '--scale')}")  # first: a --set scale=... still wins
    cfg = load_render_config(args.config, overrides)
    summary = render_dataset(cfg, args.out, shard=shard, overwrite=args.overwrite, progress=not args.no_progress)
    print(f"{summary.rendered} frames rendered, {summary.skipped} already present, "
          f"{summary.seconds:.1f} s -> {args.out} ({', '.join(summary.sequences)})")
    return 0
