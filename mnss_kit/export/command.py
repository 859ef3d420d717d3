"""``mnss-kit export``: a deployment bundle (manifest, NPU graph, GPU shaders and weights, golden frames)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..model.families import placement_modes
from ..ops.runtimes import DEFAULT_RUNTIME, runtime_names
from ..quantize.run import METHODS
from ..split.inputs import DEFAULT_RESOLUTION_TEXT

HELP = "write a deployment bundle: manifest.json, npu.tflite, npu_qdq.onnx, GPU shaders + weights, golden frames"

DEFAULT_GOLDEN_FRAMES = 3
DEFAULT_SEQUENCE_FRAMES = 30


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", metavar="MODEL",
                        help="checkpoint path or shipped name (quantized here), or a directory written by `mnss-kit quantize`")
    parser.add_argument("--out", required=True, metavar="BUNDLE", help="bundle directory to write")
    parser.add_argument("--checkpoint", metavar="CKPT",
                        help="with a quantize directory: the checkpoint it was quantized from (GPU weights and config; its SHA-256 "
                             "must match the one report.json records; default: the path recorded there)")
    parser.add_argument("--resolution", metavar="WxH",
                        help=f"output (HR) size the bundle runs at (default {DEFAULT_RESOLUTION_TEXT}; a quantize directory fixes it)")
    parser.add_argument("--scale", metavar="S",
                        help="the bundle's upscaling factor (2, 3, 4 or a quality mode such as 1.5 or 1.7, in [1.25, 4]; "
                             "default: the model's): the LR size is round_half_up(WxH / S) per axis (1280x720 at 1.5: 853x480); "
                             "a family of integer scales takes only its own")
    parser.add_argument("--device", metavar="NAME", help="device profile (mnss_kit/configs/devices): records the GPU/NPU placement and estimates")
    parser.add_argument("--placement", choices=placement_modes(), default="default", help="placement mode for --device (default: the model's split)")
    parser.add_argument("--data", metavar="DIR",
                        help="dataset at the model's scale for calibration, and for golden frames when a sequence has the "
                             "bundle's LR size (else they are rendered, with a warning; default: render both at the model's scale)")
    parser.add_argument("--method", choices=METHODS, default="minmax", help="activation range method when quantizing (default: minmax)")
    parser.add_argument("--profile", choices=runtime_names("litert"), default=DEFAULT_RUNTIME,
                        help=f"runtime whose kernels make the golden frames and whose rounding the shaders' NPU input "
                             f"takes (default: {DEFAULT_RUNTIME})")
    parser.add_argument("--golden-frames", type=int, default=DEFAULT_GOLDEN_FRAMES, metavar="N",
                        help=f"consecutive golden frames (default {DEFAULT_GOLDEN_FRAMES})")
    parser.add_argument("--sequence", metavar="DIR",
                        help="dataset whose first sequence at the bundle's LR size the bundle carries for the app to play "
                             "(every input the manifest lists, compressed)")
    parser.add_argument("--frames", type=int, default=DEFAULT_SEQUENCE_FRAMES, metavar="N",
                        help=f"frames of --sequence to carry (default {DEFAULT_SEQUENCE_FRAMES})")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing bundle directory")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..fileio import check_output
    from .run import ExportRequest, export

    from ..ops.scale import parse_scale

    check_output(args.out, "directory")
    scale = parse_scale(args.scale, "--scale") if args.scale is not None else None  # one line for 0.5, 1.0, nan, 9
    request = ExportRequest(
        model=args.model,
        out=Path(args.out),
        checkpoint=args.checkpoint,
        resolution=args.resolution,
        scale=scale,
        device=args.device,
        placement=args.placement,
        data=Path(args.data) if args.data else None,
        method=args.method,
        profile=args.profile,
        golden_frames=args.golden_frames,
        sequence=Path(args.sequence) if args.sequence else None,
        sequence_frames=args.frames,
        overwrite=args.overwrite,
        progress=not args.no_progress,
    )
    manifest = export(request)
    files = manifest["files"]
    total = sum(f["bytes"] for f in files.values())
    w, h = manifest["hr_size"]
    lw, lh = manifest["lr_size"]
    print(f"wrote {request.out}: {manifest['model']['id']} x{manifest['scale']} at {w}x{h} (LR {lw}x{lh}), "
          f"{len(manifest['schedule']['steps'])} steps, {len(manifest['golden']['frames'])} golden frames, "
          f"{_sequence_note(manifest)}{len(files)} files ({total / 1e6:.1f} MB), format version {manifest['format_version']}")
    return 0


def _sequence_note(manifest: dict) -> str:
    sequence = manifest.get("sequence")
    if not sequence:
        return ""
    stored = sum(manifest["files"][a["file"]]["bytes"] for a in sequence["arrays"].values())
    return f"a {sequence['frame_count']}-frame sequence ({stored / 1e6:.1f} MB compressed), "
