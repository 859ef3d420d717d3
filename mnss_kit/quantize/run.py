"""The quantize stage's functions: calibrate on recurrent runs, quantize the NPU stage, compare fp32 and int8.

:func:`quantize` is the stage's entry function (what ``mnss-kit quantize`` runs); the helpers
below it serve the export stage and the study scripts too.  Light at import: torch and the
runtimes load inside the functions.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..ops.runtimes import DEFAULT_RUNTIME

METHODS = ("minmax", "percentile", "entropy", "mse")  # activation range methods (quantize.calibrate)
DEFAULT_DATA_CONFIG = "tiny"  # rendered for calibration when no data is given
CALIBRATION_SAMPLES = 24  # NPU-stage inputs recorded from recurrent runs
PIPELINE_FRAMES = 12  # frames per sequence of the fp32-vs-int8 comparison
QUALITY_METRICS = ("psnr", "ssim", "if_ssim")


@dataclass
class QuantizeRequest:
    model: str  # checkpoint path or shipped name
    out: Path
    data: Path | None = None  # calibration data (None: render DEFAULT_DATA_CONFIG)
    method: str = "minmax"
    a16: int = 0  # tensors given 16-bit activations
    frames: int = CALIBRATION_SAMPLES
    qat: int = 0  # quantization-aware fine-tune steps
    eval_data: Path | None = None  # held-out data of the fp32-vs-int8 comparison (None: the calibration data)
    pipeline_frames: int = PIPELINE_FRAMES  # 0 skips the comparison
    eval_runtime: str = DEFAULT_RUNTIME
    overwrite: bool = False
    progress: bool = True


def quantize(request: QuantizeRequest):
    """Quantize ``request.model``'s NPU stage and write its files to ``request.out`` atomically;
    returns ``(artifacts, {file: bytes written})``."""
    import logging
    import tempfile

    from ..errors import UserError
    from ..fileio import atomic_directory
    from ..model.checkpoint import bundle_pattern, identity, load
    from ..model.families import family_of, npu_module
    from .stage import QuantizeOptions, quantize_module, write_artifacts

    log = logging.getLogger(__name__)
    r = request
    if r.frames < 1:
        raise UserError("--frames must be at least 1")
    if r.a16 < 0 or r.qat < 0 or r.pipeline_frames < 0:
        raise UserError("--a16, --qat and --pipeline-frames take a count >= 0")
    if r.eval_data and not r.pipeline_frames:
        raise UserError("--eval-data is for the fp32-vs-int8 comparison, which --pipeline-frames 0 skips")
    if r.out.exists() and any(r.out.iterdir()) and not r.overwrite:
        raise UserError(f"output directory {r.out} exists and is not empty (use --overwrite)")
    model, record = load(r.model)
    model.eval()
    family = family_of(model)
    with tempfile.TemporaryDirectory(prefix="mnss-quantize-") as tmp:
        if r.eval_data:  # fail before the slow part
            open_data(r.eval_data, model.scale, "evaluation", family)
        data = r.data if r.data else render_calibration_data(Path(tmp), progress=r.progress, scale=model.scale,
                                                             jitter=bundle_pattern(record, model.scale))
        sequences = open_data(data, model.scale, family=family)
        log.info("recording %d NPU-stage inputs from recurrent runs on %s", r.frames, data)
        samples = calibration_samples(model, sequences, r.frames, progress=r.progress)
        options = QuantizeOptions(method=r.method, int16=r.a16, qat_steps=r.qat)
        if r.a16:  # before the quantization's runtime passes
            check_int16_count(r.a16, npu_module(model), samples)
        art = quantize_module(npu_module(model), samples, options, name=Path(r.model).stem)
        if len(art.report.get("int16") or []) < r.a16:
            warn_int16_shortfall(r.a16, art.report, log)
        art.report["data"] = str(r.data) if r.data else f"rendered mnss_kit/configs/data/{DEFAULT_DATA_CONFIG}.yaml"
        art.report["checkpoint"] = identity(r.model, record)  # export checks it is given this very file
        if r.pipeline_frames:
            eval_dir = r.eval_data if r.eval_data else data
            label = str(eval_dir) if r.eval_data or r.data else art.report["data"]
            art.report.update(int8_report(model, art, eval_dir, r.pipeline_frames, r.eval_runtime, bool(r.eval_data), label, r.progress))
    with atomic_directory(r.out, overwrite=r.overwrite) as staging:
        files = write_artifacts(art, staging)
    return art, files


def check_int16_count(wanted: int, module, samples) -> None:
    """``--a16 N`` above the activation tensors of the NPU stage's graph is refused (nothing is
    written) instead of being clamped."""
    import numpy as np
    import torch

    from ..errors import UserError
    from .trace import trace

    graph = trace(module.eval(), [torch.from_numpy(np.asarray(x, np.float32)) for x in samples[0]])
    tensors = len(graph.activations())
    if wanted > tensors:
        raise UserError(f"--a16 {wanted}: the NPU graph has {tensors} activation tensors; ask for at most {tensors}")


def warn_int16_shortfall(wanted: int, report: dict, log) -> None:
    """Fewer tensors made 16-bit than asked: LiteRT cannot hold some of them in int16; say so."""
    chosen, skipped = report.get("int16") or [], report.get("int16_skipped") or {}
    first = next(iter(skipped.items()), ("-", "-"))
    log.warning("--a16 %d: %d tensor(s) given 16-bit activations; %d of the most sensitive cannot be int16 in LiteRT "
                "(first: '%s', %s)", wanted, len(chosen), len(skipped), *first)


def render_calibration_data(root: Path, progress: bool, with_reference: bool = True, overrides: list[str] | None = None,
                            scale: int = 2, jitter: str | None = None) -> Path:
    """Render the default calibration data config into ``root`` (EGL) at the model's ``scale`` and
    ``jitter`` pattern (None: the config's); returns the dataset directory.

    Without ``with_reference`` the HR reference gets one sample per pixel: calibration reads LR
    frames only, which do not depend on the HR sample count, and the supersampled reference (what
    the fp32-vs-int8 comparison needs) is what makes the full render slow.
    """
    from ..render.config import load_render_config
    from ..render.run import render_dataset

    overrides = [*(overrides or []), *([] if with_reference else ["hr_samples=1"]), f"scale={scale}",
                 *([f"jitter={jitter}"] if jitter else [])]
    render_dataset(load_render_config(DEFAULT_DATA_CONFIG, overrides or None), root, progress=progress)
    return root


def open_data(root: Path, scale: int, role: str = "calibration", family=None):
    """Sequences under ``root``, after checking their scale matches the model's, with the G-buffers
    ``family`` (a ``model.family.Family``; None: the base buffers only) reads."""
    from ..dataset.loader import eval_sequences
    from ..errors import UserError

    if not root.is_dir():
        raise UserError(f"{role} data directory not found: {root}")
    sequences = eval_sequences(root, hr_buffers=family.hr_inputs if family else (),
                               lr_buffers=family.lr_buffers if family else (), progress=False,
                               needed_by=f"the {family.name} family" if family else "")
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
    """``mnss_kit.eval.loop.evaluate`` of ``fp32`` (the float model) and of one method per int8 variant.

    ``variants``: ``{name: (QuantizedArtifacts, LiteRT runtime name)}``.  Every
    method sees the same frames in one run, so the per-frame numbers are
    paired.  ``max_frames``: frames per sequence (None: all).
    """
    from ..eval.methods import model_method
    from ..eval.loop import evaluate

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
        "evaluator": "mnss_kit.eval.loop.evaluate (as mnss-kit eval): recurrent, history from each method's own output",
        "gpu_part": "PyTorch float32 (the model's GPU stages, identical in both methods)",
        "int8_runtime": runtime,
        "delta": "int8 - fp32",
    }
