"""``mnss-kit eval``: a model against bicubic and TAAU on full sequences."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "Evaluate a model and baselines on a dataset (PSNR, SSIM, IF-SSIM, temporal error, cut recovery)."

METHOD_NAMES = ("model", "model_nohist", "bicubic", "taau")


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
                        help=f"methods to run (default: all of {', '.join(METHOD_NAMES)}; without a model: the baselines)")
    parser.add_argument("--flip", action="store_true", help="also compute FLIP (slower)")
    parser.add_argument("--max-frames", type=_positive_int, metavar="N", help="evaluate at most N frames of each sequence")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..fileio import check_output

    for path, kind in ((args.json, "file"), (args.csv, "file"), (args.crops, "directory")):
        if path:
            check_output(path, kind)

    from ..dataset import format as fmt
    from ..errors import UserError
    from .methods import default_methods
    from .report import format_table, write_csv, write_json
    from .run import evaluate
    model, info = _load_model(args.model, args.data)
    scale = info["scale"] if info else fmt.read_meta(fmt.find_sequences(args.data)[0]).scale
    available = default_methods(model, scale)
    wanted = args.methods or list(available)
    missing = [m for m in wanted if m not in available]
    if missing:
        raise UserError(f"method(s) {', '.join(missing)} need a model (MODEL is 'none')")
    methods = {name: available[name] for name in wanted}
    result = evaluate(
        methods,
        args.data,
        scale=scale,
        max_frames=args.max_frames,
        flip=args.flip,
        crops_dir=args.crops,
        progress=not args.no_progress,
        model_info=info,
    )
    if args.csv:
        write_csv(args.csv, result["per_frame"])
    if args.json:
        write_json(args.json, result)
    print(format_table(result))
    return 0


def _load_model(name_or_path: str, data_dir: str):
    """``(model, info)`` from a checkpoint, or ``(None, None)`` for 'none'."""
    if name_or_path.lower() == "none":
        return None, None
    import logging

    from ..dataset import format as fmt
    from ..errors import UserError
    from ..model.checkpoint import load
    from ..model.macs import count_macs

    model, record = load(name_or_path)
    scale = int(record.get("scale") or model.scale)
    meta = fmt.read_meta(fmt.find_sequences(data_dir)[0])
    if meta.scale != scale:
        raise UserError(f"{data_dir}: data is x{meta.scale} but the model is x{scale}")
    pattern = record.get("jitter_pattern")
    if pattern and pattern != meta.jitter_pattern:
        logging.getLogger(__name__).warning(
            "model trained with the '%s' jitter pattern, data uses '%s'", pattern, meta.jitter_pattern)
    macs = record.get("macs") or count_macs(model).to_dict()
    info = {
        "name": record.get("name") or Path(name_or_path).stem,
        "source": str(name_or_path),
        "family": record.get("family"),
        "scale": scale,
        "jitter_pattern": pattern,
        "parameters": sum(p.numel() for p in model.parameters()),
        "macs_per_pixel": macs["macs_per_pixel"],
        "npu_macs_per_pixel": macs.get("npu_macs_per_pixel"),
        "gpu_macs_per_pixel": macs.get("gpu_macs_per_pixel"),
        "config": record.get("config"),
        "data_fingerprint": record.get("data_fingerprint"),
        "code_version": record.get("code_version"),
    }
    return model, info
