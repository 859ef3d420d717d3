"""``mnss-kit split``: place a model's stages on the GPU or NPU of a device and estimate the cost."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..model.families import placement_modes
from .inputs import DEFAULT_RESOLUTION_TEXT

HELP = "place each stage on GPU or NPU for a device profile and estimate ms per stage (estimates)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "model",
        help="checkpoint path or shipped name; a model config (mnss_kit/configs/models NAME or path) also works: "
        "placement and estimates do not depend on the weights",
    )
    parser.add_argument("--device", required=True, help="device profile: a YAML path or a name under mnss_kit/configs/devices/")
    parser.add_argument("--placement", choices=placement_modes(), default="default",
                        help="default (the model's split), all-gpu, aa-on-npu, or auto (lowest estimate)")
    parser.add_argument("--auto", action="store_const", const="auto", dest="placement",
                        help="same as --placement auto")
    parser.add_argument("--resolution", default=DEFAULT_RESOLUTION_TEXT, metavar="WxH",
                        help=f"output (HR) size the estimates are made for (default {DEFAULT_RESOLUTION_TEXT})")
    parser.add_argument("--scale", metavar="S",
                        help="the upscaling factor to estimate at: 2, 3, 4 or a quality mode in [1.25, 4] such as 1.5 "
                             "(default: the model's); the LR size is round(WxH / S) per axis (1280x720 at 1.5: 853x480); "
                             "a family of integer scales takes only its own")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the placement as JSON")


def run(args: argparse.Namespace) -> int:
    from ..fileio import atomic_write_json, check_output
    from ..ops.scale import parse_scale

    scale = parse_scale(args.scale, "--scale") if args.scale is not None else None  # one line for 0.5, 1.0, nan, 9
    if args.json:
        check_output(args.json, "file")

    from .report import format_text
    from .run import run_split

    plan = run_split(args.model, args.device, args.placement, args.resolution, scale)
    print(format_text(plan))
    if args.json:
        atomic_write_json(args.json, plan.to_dict())
    return 0
