"""``mnss-kit size``: the smallest model of a ladder that is good enough on a user's scene."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "train a ladder of model sizes on a scene and choose the smallest that meets quality targets (and a device budget)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..eval.command import _positive_int

    parser.add_argument("--data", type=Path, nargs="+", required=True, metavar="DIR",
                        help="the scene: sequence directories or directories of sequences")
    parser.add_argument("--test", type=Path, nargs="+", metavar="DIR",
                        help="held-out sequences of the scene (default: the last --held-out sequences of --data)")
    parser.add_argument("--held-out", type=_positive_int, default=1, metavar="K",
                        help="without --test: hold the last K sequences of --data out of training (default: %(default)s)")
    parser.add_argument("--target", action="append", required=True, metavar="SPEC",
                        help="quality target, repeatable (all must hold): within:DB (PSNR at most DB below the largest "
                             "rung), taau:DB (PSNR at least DB above TAAU), psnr:FLOOR, ssim:FLOOR, if_ssim:FLOOR")
    parser.add_argument("--budget-ms", type=float, metavar="MS", help="estimated frame ms the model may take on --device")
    parser.add_argument("--device", metavar="NAME", help="device profile of --budget-ms (mnss_kit/configs/devices)")
    parser.add_argument("--scale", metavar="S",
                        help="the scale to size at, which the data must be at: 2, 3, 4 or a quality mode in [1.25, 4] "
                             "such as 1.5 (default: the data's)")
    parser.add_argument("--ladder", nargs="+", metavar="CONFIG",
                        help="model configs to try, CONFIG+detail for an ntaau_lr config with a detail branch fitted on "
                             "the scene (as finetune --detail fits it), CONFIG+detailN with one of width N; a config at another scale is trained at the data's when its family "
                             "runs at any scale, refused otherwise (default: every shipped config at the scale, or at a "
                             "scale none is shipped at, such as 1.5, every config of a family that runs at any scale)")
    parser.add_argument("--steps", type=_positive_int, default=2000, help="training steps per rung (default: %(default)s)")
    parser.add_argument("--minutes", type=float, metavar="M", help="wall-time cap per rung (rows say when it stopped a run)")
    parser.add_argument("--seeds", type=_positive_int, default=1, metavar="N",
                        help="train each rung N times (the config's seed, then the next ones) and judge it by the mean; "
                             "its best seed is the checkpoint export takes (default: %(default)s)")
    parser.add_argument("--detail-minutes", type=float, metavar="M",
                        help="fitting time of the branch of each CONFIG+detail rung, recording included (default: "
                             "what mnss-kit finetune --detail gives it in its default budget)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="typed override for every rung, e.g. train.batch_size=8 (repeatable)")
    parser.add_argument("--output-size", default="1280x720", metavar="WxH", help="HR size of the device estimates (default: %(default)s)")
    parser.add_argument("--max-frames", type=_positive_int, metavar="N", help="evaluate at most N frames of each held-out sequence")
    parser.add_argument("--out", type=Path, default=Path("runs/size"),
                        help="directory for runs/, size.json, size.md and size.png; rerunning continues it (default: %(default)s, "
                             "under the working directory)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..errors import UserError
    from ..fileio import atomic_write_text, check_output
    from ..split.inputs import parse_resolution
    from ..ops.scale import parse_scale
    from .select import Budget, parse_target

    scale = None if args.scale is None else parse_scale(args.scale, "--scale")  # 0.5, 1.0, nan, 9: one line
    check_output(args.out, "into")
    targets = [parse_target(t) for t in args.target]
    if (args.budget_ms is None) != (args.device is None):
        raise UserError("--budget-ms and --device go together: a budget is estimated ms on one device profile")
    if args.budget_ms is not None and not args.budget_ms > 0:
        raise UserError(f"--budget-ms must be positive, got {args.budget_ms}")
    for flag, value in (("--minutes", args.minutes), ("--detail-minutes", args.detail_minutes)):
        if value is not None and not value > 0:
            raise UserError(f"{flag} must be positive, got {value}")
    budget = Budget(args.device, args.budget_ms) if args.device else None
    if budget:
        from ..split.device import load_device

        load_device(budget.device)  # an unknown profile fails before any training

    from .charts import markdown, write_chart
    from .run import SizeRequest, run_size

    request = SizeRequest(data=args.data, targets=targets, out=args.out, test=args.test, held_out=args.held_out,
                          ladder=args.ladder, overrides=args.overrides, steps=args.steps, minutes=args.minutes, budget=budget,
                          output_size=parse_resolution(args.output_size, "--output-size"), max_frames=args.max_frames,
                          scale=scale, seeds=args.seeds, progress=not args.no_progress,
                          **({} if args.detail_minutes is None else {"detail_minutes": args.detail_minutes}))
    doc = run_size(request)
    table = markdown(doc)
    atomic_write_text(args.out / "size.md", table)
    write_chart(doc, args.out / "size.png")
    print(table)
    print(f"wrote {args.out / 'size.json'}, {args.out / 'size.md'} and {args.out / 'size.png'}")
    if doc["choice"] is None:
        print("no rung meets the targets: loosen them, raise the budget or extend the ladder")
        return 1
    print(f"export it with: mnss-kit export {args.out / 'size.json'} --out BUNDLE")
    return 0
