"""``mnss-kit quantize``: int8 post-training quantization of a model's NPU stage (``Family.npu_stages``).

Calibration records the stage's inputs on recurrent runs of the float model,
spread over every calibration sequence.  The report compares the float
pipeline (fp32) with the same pipeline whose NPU stage runs the written
``npu.tflite`` (int8) through :func:`mnss_kit.eval.loop.evaluate`, the code
behind ``mnss-kit eval``: same frames, same metrics, one run.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..ops.runtimes import DEFAULT_RUNTIME, runtime_names
from .run import CALIBRATION_SAMPLES, DEFAULT_DATA_CONFIG, METHODS, PIPELINE_FRAMES

HELP = "quantize the NPU stage to int8: npu.tflite, npu_qdq.onnx, encodings.json, report (calibrated on recurrent runs)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", metavar="MODEL", help="checkpoint path or shipped model name")
    parser.add_argument("--data", metavar="DIR", help=f"dataset directory for calibration (default: render mnss_kit/configs/data/{DEFAULT_DATA_CONFIG}.yaml)")
    parser.add_argument("--method", choices=METHODS, default="minmax", help="activation range method (default: minmax)")
    parser.add_argument("--out", metavar="DIR", help="output directory (default: <model>-int8)")
    parser.add_argument("--a16", type=int, default=0, metavar="N", help="give the N most sensitive tensors 16-bit activations (A16W8)")
    parser.add_argument("--frames", type=int, default=CALIBRATION_SAMPLES, metavar="N",
                        help=f"calibration samples recorded from recurrent runs, spread evenly over every sequence (default: {CALIBRATION_SAMPLES})")
    parser.add_argument("--qat", type=int, default=0, metavar="STEPS", help="short quantization-aware fine-tune (distillation) after PTQ")
    parser.add_argument("--eval-data", metavar="DIR",
                        help="held-out dataset for the fp32-vs-int8 comparison in the report (default: the calibration data)")
    parser.add_argument("--pipeline-frames", type=int, default=PIPELINE_FRAMES, metavar="N",
                        help=f"frames per sequence for the fp32-vs-int8 comparison (default: {PIPELINE_FRAMES}; 0: skip)")
    parser.add_argument("--eval-runtime", choices=runtime_names("litert"), default=DEFAULT_RUNTIME,
                        help=f"LiteRT kernels that run the int8 stage in that comparison (default: {DEFAULT_RUNTIME})")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output directory")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..fileio import check_output

    out = Path(args.out) if args.out else Path(f"{Path(args.model).stem}-int8")
    check_output(out, "directory")  # before the imports too: they take seconds

    from .run import QuantizeRequest, quantize
    from .artifacts import comparison_table, summary_table

    art, files = quantize(QuantizeRequest(
        model=args.model, out=out, data=Path(args.data) if args.data else None, method=args.method, a16=args.a16,
        frames=args.frames, qat=args.qat, eval_data=Path(args.eval_data) if args.eval_data else None,
        pipeline_frames=args.pipeline_frames, eval_runtime=args.eval_runtime, overwrite=args.overwrite,
        progress=not args.no_progress))
    print(summary_table(art.report))
    print()
    for runtime, m in art.report["output"].items():
        print(f"{runtime:24s} output PSNR vs float stage {m['psnr_db']:.2f} dB")
    agree = art.report["agreement"]
    print(f"LiteRT vs ONNX Runtime on int8 tensors: per op <= {agree['per_op_max_lsb']} LSB; whole graph <= "
          f"{agree['end_to_end_max_lsb_xnnpack']} LSB (XNNPACK), <= {agree['end_to_end_max_lsb']} LSB (reference kernels)")
    if "delta" in art.report:
        print()
        print(comparison_table(art.report))
    print(f"wrote {', '.join(f'{k} ({v} B)' for k, v in files.items())}, report.json, report.md -> {out}")
    return 0
