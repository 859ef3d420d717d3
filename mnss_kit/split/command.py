"""``mnss-kit split``: place a model's stages on the GPU or NPU of a device and estimate the cost."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..model.families import placement_modes

HELP = "place each stage on GPU or NPU for a device profile and estimate ms per stage (estimates)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "model",
        help="checkpoint path or shipped name; a model config (configs/models NAME or path) also works: "
        "placement and estimates do not depend on the weights",
    )
    parser.add_argument("--device", required=True, help="device profile: a YAML path or a name under configs/devices/")
    parser.add_argument("--placement", choices=placement_modes(), default="default",
                        help="default (the model's split), all-gpu, aa-on-npu, or auto (lowest estimate)")
    parser.add_argument("--auto", action="store_const", const="auto", dest="placement",
                        help="same as --placement auto")
    parser.add_argument("--resolution", default="1280x720", metavar="WxH",
                        help="output (HR) size the estimates are made for (default 1280x720)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the placement as JSON")


def run(args: argparse.Namespace) -> int:
    from ..fileio import atomic_write_json, check_output

    if args.json:
        check_output(args.json, "file")

    from .device import load_device
    from .plan import split_model
    from .report import format_text
    resolution = parse_resolution(args.resolution)
    device = load_device(args.device)
    model, name = load_model(args.model)
    require_scale_multiple(resolution, model.scale)
    plan = split_model(model, device, args.placement, resolution, model_name=name)
    print(format_text(plan))
    if args.json:
        atomic_write_json(args.json, plan.to_dict())
    return 0


def parse_resolution(text: str) -> tuple[int, int]:
    """``"1280x720"`` -> ``(1280, 720)``."""
    from ..errors import UserError

    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise UserError(f"--resolution must look like 1280x720, got '{text}'")
    w, h = (int(p) for p in parts)
    if w < 1 or h < 1:
        raise UserError(f"--resolution must be positive, got '{text}'")
    return w, h


def require_scale_multiple(size: tuple[int, int], scale: int) -> None:
    """The one rule for an output (HR) size, in every command that takes one: whole LR pixels."""
    from ..errors import UserError

    w, h = size
    if w % scale or h % scale:
        raise UserError(f"output size {w}x{h} is not a multiple of the model's scale {scale} "
                        f"(e.g. {w // scale * scale or scale}x{h // scale * scale or scale})")


def load_model(name_or_path: str):
    """``(model, label)`` from a checkpoint (path or shipped name), else from a model config."""
    from ..errors import UserError
    from ..model import checkpoint
    from ..model.config import config_names, load_model_config
    from ..model.families import build_model

    path = Path(name_or_path)
    if path.suffix != ".yaml" and (path.is_file() or name_or_path in checkpoint.shipped_names()):
        model, _ = checkpoint.load(name_or_path)
        return model, path.stem
    if path.suffix == ".yaml" or name_or_path in config_names():
        return build_model(load_model_config(name_or_path)).eval(), f"{path.stem} (config)"
    shipped = ", ".join(checkpoint.shipped_names()) or "none shipped"
    raise UserError(
        f"no model '{name_or_path}': give a checkpoint path, a shipped name ({shipped}) "
        f"or a model config ({', '.join(config_names())})"
    )
