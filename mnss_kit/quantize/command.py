"""``mnss-kit quantize``: int8 post-training quantization of a model's NPU stage (``Family.npu_stages``).

Calibration records the stage's inputs on recurrent runs of the float model,
spread over every calibration sequence.  The report compares the float
pipeline (fp32) with the same pipeline whose NPU stage runs the written
``npu.tflite`` (int8) through :func:`mnss_kit.eval.run.evaluate`, the code
behind ``mnss-kit eval``: same frames, same metrics, one run.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..ops.runtimes import DEFAULT_RUNTIME, runtime_names

HELP = "quantize the NPU stage to int8: npu.tflite, npu_qdq.onnx, encodings.json, report (calibrated on recurrent runs)"
METHODS = ("minmax", "percentile", "entropy", "mse")
DEFAULT_DATA_CONFIG = "tiny"
QUALITY_METRICS = ("psnr", "ssim", "if_ssim")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", metavar="MODEL", help="checkpoint path or shipped model name")
    parser.add_argument("--data", metavar="DIR", help=f"dataset directory for calibration (default: render configs/data/{DEFAULT_DATA_CONFIG}.yaml)")
    parser.add_argument("--method", choices=METHODS, default="minmax", help="activation range method (default: minmax)")
    parser.add_argument("--out", metavar="DIR", help="output directory (default: <model>-int8)")
    parser.add_argument("--a16", type=int, default=0, metavar="N", help="give the N most sensitive tensors 16-bit activations (A16W8)")
    parser.add_argument("--frames", type=int, default=24, metavar="N",
                        help="calibration samples recorded from recurrent runs, spread evenly over every sequence (default: 24)")
    parser.add_argument("--qat", type=int, default=0, metavar="STEPS", help="short quantization-aware fine-tune (distillation) after PTQ")
    parser.add_argument("--eval-data", metavar="DIR",
                        help="held-out dataset for the fp32-vs-int8 comparison in the report (default: the calibration data)")
    parser.add_argument("--pipeline-frames", type=int, default=12, metavar="N",
                        help="frames per sequence for the fp32-vs-int8 comparison (default: 12; 0: skip)")
    parser.add_argument("--eval-runtime", choices=runtime_names("litert"), default=DEFAULT_RUNTIME,
                        help=f"LiteRT kernels that run the int8 stage in that comparison (default: {DEFAULT_RUNTIME})")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing output directory")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    import logging
    import tempfile

    from ..errors import UserError
    from ..fileio import atomic_directory, check_output

    name = Path(args.model).stem
    out = Path(args.out) if args.out else Path(f"{name}-int8")
    check_output(out, "directory")  # before the imports too: they take seconds

    from ..model.checkpoint import identity, load
    from ..model.families import family_of, npu_module
    from .artifacts import comparison_table, summary_table
    from .stage import QuantizeOptions, quantize_module, write_artifacts

    log = logging.getLogger(__name__)
    if args.frames < 1:
        raise UserError("--frames must be at least 1")
    if args.a16 < 0 or args.qat < 0 or args.pipeline_frames < 0:
        raise UserError("--a16, --qat and --pipeline-frames take a count >= 0")
    if args.eval_data and not args.pipeline_frames:
        raise UserError("--eval-data is for the fp32-vs-int8 comparison, which --pipeline-frames 0 skips")
    if out.exists() and any(out.iterdir()) and not args.overwrite:
        raise UserError(f"output directory {out} exists and is not empty (use --overwrite)")
    model, record = load(args.model)
    model.eval()
    progress = not args.no_progress
    with tempfile.TemporaryDirectory(prefix="mnss-quantize-") as tmp:
        if args.eval_data:  # fail before the slow part
            open_data(Path(args.eval_data), model.scale, "evaluation", family_of(model).hr_inputs)
        data = Path(args.data) if args.data else render_calibration_data(Path(tmp), progress=progress)
        sequences = open_data(data, model.scale, hr_buffers=family_of(model).hr_inputs)
        log.info("recording %d NPU-stage inputs from recurrent runs on %s", args.frames, data)
        samples = calibration_samples(model, sequences, args.frames, progress=progress)
        options = QuantizeOptions(method=args.method, int16=args.a16, qat_steps=args.qat)
        art = quantize_module(npu_module(model), samples, options, name=name)
        art.report["data"] = str(args.data) if args.data else f"rendered configs/data/{DEFAULT_DATA_CONFIG}.yaml"
        art.report["checkpoint"] = identity(args.model, record)  # export checks it is given this very file
        if args.pipeline_frames:
            eval_dir = Path(args.eval_data) if args.eval_data else data
            label = str(eval_dir) if args.eval_data or args.data else art.report["data"]
            art.report.update(int8_report(model, art, eval_dir, args.pipeline_frames, args.eval_runtime, bool(args.eval_data), label, progress))
    with atomic_directory(out, overwrite=args.overwrite) as staging:
        files = write_artifacts(art, staging)
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


def render_calibration_data(root: Path, progress: bool) -> Path:
    """Render the tiny built-in data config into ``root`` (EGL); returns the dataset directory."""
    from ..render.config import load_render_config
    from ..render.writer import render_dataset

    render_dataset(load_render_config(DEFAULT_DATA_CONFIG), root, progress=progress)
    return root


def open_data(root: Path, scale: int, role: str = "calibration", hr_buffers: tuple[str, ...] = ()):
    """Sequences under ``root``, after checking their scale matches the model's; ``hr_buffers``:
    the HR G-buffers the model's family reads (``Family.hr_inputs``)."""
    from ..dataset.loader import eval_sequences
    from ..errors import UserError

    if not root.is_dir():
        raise UserError(f"{role} data directory not found: {root}")
    sequences = eval_sequences(root, hr_buffers=hr_buffers, progress=False)
    if not sequences:
        raise UserError(f"no sequences under {root}")
    for seq in sequences:
        if seq.meta.scale != scale:
            raise UserError(f"{role} sequence '{seq.name}' is x{seq.meta.scale} but the model is x{scale}")
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


def sample_frames(lengths: list[int], count: int) -> list[list[int]]:
    """Frame indices to record, per sequence: ``count`` in total, split as evenly as the
    sequences allow and spread evenly over each one (first and last frame included)."""
    import numpy as np

    quotas = [0] * len(lengths)
    remaining = count
    while remaining > 0 and any(q < n for q, n in zip(quotas, lengths)):
        for i, n in enumerate(lengths):
            if remaining and quotas[i] < n:
                quotas[i] += 1
                remaining -= 1
    picks = []
    for q, n in zip(quotas, lengths):
        picks.append(sorted({int(round(x)) for x in np.linspace(0, n - 1, q)}) if q else [])
    return picks


def calibration_samples(model, sequences, count: int, progress: bool = False) -> list[list]:
    """NPU-stage inputs recorded while the float model runs each sequence recurrently.

    The ``count`` recorded frames are spread over all sequences (see
    :func:`sample_frames`), so the history in each sample is the model's own
    output after the frames before it.  Returns lists of NCHW float32 arrays.
    """
    import torch
    from tqdm import tqdm

    from ..model.families import npu_module
    from .calibrate import InputRecorder

    picks = sample_frames([len(s) for s in sequences], count)
    samples: list[list] = []
    with torch.no_grad(), tqdm(total=sum(len(p) for p in picks), unit="sample", desc="recording", disable=not progress) as bar:
        for seq, wanted in zip(sequences, picks):
            state, wanted = None, set(wanted)
            for t, frame in enumerate(checked_frames([seq])):
                if not wanted:
                    break
                if t in wanted:
                    with InputRecorder(npu_module(model)) as rec:
                        _, _, state = model(frame, state)
                    samples.extend(rec.samples)
                    wanted.discard(t)
                    bar.update(1)
                else:
                    _, _, state = model(frame, state)
    return samples


def int8_model(model, art, runtime: str = DEFAULT_RUNTIME):
    """A copy of the float ``model`` whose NPU stage runs ``art.tflite`` in LiteRT (a LiteRT ``runtime``'s kernels)."""
    import copy

    from ..model.families import npu_stage_name
    from .runtime import QuantizedStage, swap_stage

    quantized = copy.deepcopy(model).eval()
    swap_stage(quantized, npu_stage_name(model), QuantizedStage.build(art.graph, art.tflite, runtime))
    return quantized


def evaluate_int8(model, variants: dict, data_dir: Path, max_frames: int | None, progress: bool = True) -> dict:
    """``mnss_kit.eval.run.evaluate`` of ``fp32`` (the float model) and of one method per int8 variant.

    ``variants``: ``{name: (QuantizedArtifacts, LiteRT runtime name)}``.  Every
    method sees the same frames in one run, so the per-frame numbers are
    paired.  ``max_frames``: frames per sequence (None: all).
    """
    from ..eval.methods import model_method
    from ..eval.run import evaluate

    methods = {"fp32": model_method(model)}
    for name, (art, runtime) in variants.items():
        methods[name] = model_method(int8_model(model, art, runtime))
    return evaluate(methods, data_dir, scale=model.scale, max_frames=max_frames, progress=progress)


def int8_report(model, art, data_dir: Path, max_frames: int, runtime: str, held_out: bool, data_label: str, progress: bool) -> dict:
    """report.json's fp32-vs-int8 part: ``fp32``, ``int8``, ``delta``, ``sequences`` and ``evaluation``."""
    result = evaluate_int8(model, {"int8": (art, runtime)}, data_dir, max_frames, progress=progress)
    return {**fp32_vs_int8(result, "int8"), "evaluation": evaluation_info(result, runtime, held_out, data_label)}


def fp32_vs_int8(result: dict, int8: str = "int8", fp32: str = "fp32") -> dict:
    """``{"fp32": {psnr, ssim, if_ssim}, "int8": {...}, "delta": {...}, "sequences": [per sequence]}``
    from an :func:`evaluate_int8` result; delta = int8 - fp32 (negative: int8 is worse)."""

    def scores(stats: dict) -> dict:
        return {k: stats.get(k) for k in QUALITY_METRICS}

    def delta(a: dict, b: dict) -> dict:
        return {k: None if a[k] is None or b[k] is None else b[k] - a[k] for k in QUALITY_METRICS}

    a, b = scores(result["methods"][fp32]), scores(result["methods"][int8])
    per_sequence = []
    for seq, info in result["sequences"].items():
        sa, sb = scores(info["methods"][fp32]), scores(info["methods"][int8])
        per_sequence.append({"sequence": seq, "frames": info["frames"], "fp32": sa, "int8": sb, "delta": delta(sa, sb)})
    return {"fp32": a, "int8": b, "delta": delta(a, b), "sequences": per_sequence}


def evaluation_info(result: dict, runtime: str, held_out: bool, data_label: str) -> dict:
    """How the fp32-vs-int8 numbers were made (for report.json)."""
    return {
        "data": data_label,
        "held_out": held_out,
        "sequences": len(result["sequences"]),
        "frames": result["frames"],
        "max_frames_per_sequence": result["settings"]["max_frames"],
        "evaluator": "mnss_kit.eval.run.evaluate (as mnss-kit eval): recurrent, history from each method's own output",
        "gpu_part": "PyTorch float32 (the model's GPU stages, identical in both methods)",
        "int8_runtime": runtime,
        "delta": "int8 - fp32",
    }
