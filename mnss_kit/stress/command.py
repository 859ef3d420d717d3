"""``mnss-kit stress``: the models and the baselines on the built-in failure-case scenarios."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = ("stress scenarios (fast pan, cut, disocclusion, thin geometry, particles, light, moire, static, no jitter, "
        "figures crossing a wall, foliage strafe with a cut; one frame of NaN colour, one of Inf depth)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..eval.command import _positive_int

    from ..zoo import DEFAULT_MODEL

    parser.add_argument("--models", nargs="+", default=[DEFAULT_MODEL], metavar="MODEL",
                        help="checkpoints or shipped names to test against bicubic, TAAU and the FSR2-class upscaler (default: %(default)s)")
    parser.add_argument("--out", type=Path, default=Path("runs/stress"),
                        help="directory for stress.json, stress.md, plots/ and crops/ (default: %(default)s, under the "
                             "working directory)")
    parser.add_argument("--work", type=Path, default=Path("runs/work"),
                        help="the rendered scenarios are kept here and reused, as `mnss-kit bench` keeps its sets "
                             "(default: %(default)s)")
    parser.add_argument("--data", type=Path, help="already rendered scenario sequences (default: render mnss_kit/configs/data/stress.yaml)")
    parser.add_argument("--scale", metavar="S",
                        help="render the scenarios at this scale (as `mnss-kit render stress --scale S`; grid jitter "
                             "becomes halton where grid has no order) and run every model at it: 2, 3, 4 or a quality "
                             "mode in [1.25, 4] such as 1.5; a model whose family cannot run at S is refused "
                             "(default: the --data's scale, or the config's, x2)")
    parser.add_argument("--max-frames", type=_positive_int, metavar="N", help="evaluate at most N frames of each scenario")
    parser.add_argument("--no-crops", action="store_true", help="no image crops")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..fileio import atomic_write_json, atomic_write_text, check_output
    from ..ops.scale import parse_scale

    scale = None if args.scale is None else parse_scale(args.scale, "--scale")  # 0.5, 1.0, nan, 9: one line
    check_output(args.out, "into")
    if not args.data:
        check_output(args.work, "into")

    from .charts import write_plots
    from .run import StressRequest, run_stress
    from .verdict import markdown

    doc = run_stress(StressRequest(models=args.models, work=args.work, data=args.data, max_frames=args.max_frames,
                                   crops_dir=None if args.no_crops else args.out / "crops", progress=not args.no_progress,
                                   scale=scale))
    plots = write_plots(doc, args.out / "plots")
    atomic_write_json(args.out / "stress.json", doc)
    table = markdown(doc)
    atomic_write_text(args.out / "stress.md", table)
    print(table)
    print(f"wrote {args.out / 'stress.json'}, {args.out / 'stress.md'} and {len(plots)} plots in {args.out / 'plots'}")
    return 0
