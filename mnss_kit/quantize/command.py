"""``mnss-kit quantize``: int8 post-training quantization of a model's NPU stage (``model.recon``)."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "quantize the NPU stage to int8: npu.tflite, npu_qdq.onnx, encodings.json, report (calibrated on recurrent runs)"
METHODS = ("minmax", "percentile", "entropy", "mse")
DEFAULT_DATA_CONFIG = "tiny"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", metavar="MODEL", help="checkpoint path or shipped model name")
    parser.add_argument("--data", metavar="DIR", help=f"dataset directory for calibration (default: render configs/data/{DEFAULT_DATA_CONFIG}.yaml)")
    parser.add_argument("--method", choices=METHODS, default="minmax", help="activation range method (default: minmax)")
    parser.add_argument("--out", metavar="DIR", help="output directory (default: <model>-int8)")
    parser.add_argument("--a16", type=int, default=0, metavar="N", help="give the N most sensitive tensors 16-bit activations (A16W8)")
    parser.add_argument("--frames", type=int, default=24, metavar="N", help="calibration samples recorded from recurrent runs (default: 24)")
    parser.add_argument("--qat", type=int, default=0, metavar="STEPS", help="short quantization-aware fine-tune (distillation) after PTQ")
    parser.add_argument("--pipeline-frames", type=int, default=12, metavar="N",
                        help="frames per sequence for the float-vs-int8 recurrent comparison in the report (0: skip)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output directory")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    import logging
    import tempfile

    from ..errors import UserError
    from ..fileio import atomic_directory
    from ..model.checkpoint import load
    from .artifacts import summary_table
    from .calibrate import record_stage_inputs
    from .stage import QuantizeOptions, quantize_module, write_artifacts

    log = logging.getLogger(__name__)
    if args.frames < 1:
        raise UserError("--frames must be at least 1")
    if args.a16 < 0 or args.qat < 0:
        raise UserError("--a16 and --qat take a count >= 0")
    model, record = load(args.model)
    name = Path(args.model).stem
    out = Path(args.out) if args.out else Path(f"{name}-int8")
    if out.exists() and any(out.iterdir()) and not args.overwrite:
        raise UserError(f"output directory {out} exists and is not empty (use --overwrite)")
    with tempfile.TemporaryDirectory(prefix="mnss-quantize-") as tmp:
        data = Path(args.data) if args.data else render_calibration_data(Path(tmp), progress=not args.no_progress)
        sequences = open_data(data, model.scale)
        log.info("recording %d NPU-stage inputs from recurrent runs on %s", args.frames, data)
        samples = record_stage_inputs(model, checked_frames(sequences), "recon", limit=args.frames, progress=not args.no_progress)
        options = QuantizeOptions(method=args.method, int16=args.a16, qat_steps=args.qat)
        art = quantize_module(model.recon, samples, options, name=name)
        art.report["data"] = str(args.data) if args.data else f"rendered configs/data/{DEFAULT_DATA_CONFIG}.yaml"
        art.report["checkpoint"] = {"path": str(args.model), "family": record.get("family"), "scale": record.get("scale"), "code_version": record.get("code_version")}
        if args.pipeline_frames:
            art.report["pipeline"] = pipeline_psnr(model, art, sequences, args.pipeline_frames)
    with atomic_directory(out, overwrite=args.overwrite) as staging:
        files = write_artifacts(art, staging)
    print(summary_table(art.report))
    print()
    for runtime, m in art.report["output"].items():
        print(f"{runtime:24s} output PSNR vs float stage {m['psnr_db']:.2f} dB")
    agree = art.report["agreement"]
    print(f"LiteRT reference vs ONNX Runtime: per op <= {agree['per_op_max_lsb']} LSB, whole graph <= {agree['end_to_end_max_lsb']} LSB (int8 tensors)")
    for p in art.report.get("pipeline", []):
        print(f"{p['sequence']:24s} recurrent PSNR vs reference: float {p['float_psnr_db']:.2f} dB, int8 {p['int8_psnr_db']:.2f} dB")
    print(f"wrote {', '.join(f'{k} ({v} B)' for k, v in files.items())}, report.json, report.md -> {out}")
    return 0


def render_calibration_data(root: Path, progress: bool) -> Path:
    """Render the tiny built-in data config into ``root`` (EGL); returns the dataset directory."""
    from ..render.config import load_render_config
    from ..render.writer import render_dataset

    render_dataset(load_render_config(DEFAULT_DATA_CONFIG), root, progress=progress)
    return root


def open_data(root: Path, scale: int):
    """Sequences under ``root``, after checking their scale matches the model's."""
    from ..dataset.loader import eval_sequences
    from ..errors import UserError

    if not root.is_dir():
        raise UserError(f"calibration data directory not found: {root}")
    sequences = eval_sequences(root, progress=False)
    if not sequences:
        raise UserError(f"no sequences under {root}")
    for seq in sequences:
        if seq.meta.scale != scale:
            raise UserError(f"calibration sequence '{seq.name}' is x{seq.meta.scale} but the model is x{scale}")
    return sequences


def checked_frames(sequences):
    """Frames of every sequence in order; a UserError for a frame holding NaN or Inf."""
    import torch

    from ..errors import UserError

    for seq in sequences:
        for t, frame in enumerate(seq):
            for key, value in frame.items():
                if torch.is_floating_point(value) and not torch.isfinite(value).all():
                    raise UserError(f"sequence '{seq.name}' frame {t}: '{key}' contains NaN or Inf")
            yield frame


def pipeline_psnr(model, art, sequences, frames: int) -> list[dict]:
    """PSNR vs the HR reference of the recurrent float model and of the same model with the int8 NPU stage."""
    import torch

    from ..metrics.image import psnr
    from .runtime import QuantizedStage, swap_stage

    int8_stage = QuantizedStage.build(art.graph, art.tflite, backend="tflite", resolver="xnnpack")
    rows = []
    for seq in sequences:
        scores = {}
        for label in ("float", "int8"):
            original = swap_stage(model, "recon", int8_stage) if label == "int8" else None
            try:
                state, values = None, []
                with torch.no_grad():
                    for t, frame in enumerate(seq):
                        if t >= frames:
                            break
                        output, _, state = model(frame, state)
                        values.append(psnr(output[0].numpy(), frame["reference"][0].numpy()))
            finally:
                if original is not None:
                    swap_stage(model, "recon", original)
            scores[label] = float(sum(values) / len(values))
        rows.append({"sequence": seq.name, "frames": len(values), "runtime": "litert_xnnpack", "float_psnr_db": scores["float"], "int8_psnr_db": scores["int8"]})
    return rows
