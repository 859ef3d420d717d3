"""The NPU files of a bundle: quantized from a checkpoint at the bundle's size, or taken from ``mnss-kit quantize``.

A quantized graph has fixed shapes, and calibration data rarely has the phone's output size.
Scales and zero points do not depend on the image size, so :func:`quantize_at` calibrates
at the data's size with the quantize stage's own entry function and then :func:`retarget` s
the graph: the module is traced again at the bundle's size and every tensor takes the new
shape, keeping its quantization and (for constants) its stored integers unchanged.
"""

from __future__ import annotations

import copy
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..model.families import family_of, npu_input_shapes, npu_module
from ..fileio import read_json

log = logging.getLogger(__name__)
QUANTIZED_DIR_FILES = ("npu.tflite", "npu_qdq.onnx", "encodings.json", "report.json")  # what mnss-kit quantize writes, report.md aside


@dataclass
class NpuArtifacts:
    """``npu.tflite`` and ``npu_qdq.onnx`` bytes, and how they were made (plain data for the manifest)."""

    tflite: bytes
    onnx: bytes
    quantization: dict = field(default_factory=dict)


def retarget(graph, module, hr_size: tuple[int, int], input_shapes: list[tuple[int, ...]] | None = None):
    """``graph`` (quantized, NHWC) with every activation shape traced again for an ``hr_size`` = (W, H) input.

    Graph inputs are images at the output size (MNSS's reconstruction net) or at a fixed fraction
    of it (FuseSR's backbone reads the LR size): each keeps its calibrated ratio to the output.
    ``input_shapes`` (NCHW, ``model.families.npu_input_shapes``) replaces that rule where it does not
    hold (ntaau_lr's net reads and writes the LR size rounded up to even).  Quantization, constants
    and op structure are copied unchanged; only shapes and size options follow the new trace.
    ``ValueError`` if the new trace does not have the same tensors.
    """
    import torch

    from ..quantize.trace import trace

    width, height = hr_size
    examples = [torch.zeros(*shape) for shape in input_shapes] if input_shapes else _examples_by_ratio(graph, hr_size)
    fresh = trace(module, examples)
    out = copy.deepcopy(graph)
    for name in out.activations():
        t = out.tensors[name]
        base = name if name in fresh.tensors else name.rsplit(".", 1)[0]  # QUANTIZE conversions: "<tensor>.<dtype>"
        if base not in fresh.tensors:
            raise ValueError(f"tensor {name} is not in the graph traced at {width}x{height}")
        new = tuple(fresh.tensors[base].shape)
        if len(new) != len(t.shape) or new[0] != t.shape[0] or new[-1] != t.shape[-1]:
            raise ValueError(f"tensor {name}: traced shape {new} differs from {t.shape} beyond height and width")
        t.shape = new
    fresh_ops = {op.outputs[0]: op for op in fresh.ops}
    for op in out.ops:
        twin = fresh_ops.get(op.outputs[0])
        if twin is not None and "size" in twin.options:
            op.options["size"] = twin.options["size"]
    out.validate()
    return out


def _examples_by_ratio(graph, hr_size: tuple[int, int]) -> list:
    """Zero NCHW inputs for an ``hr_size`` output, each input keeping its calibrated ratio to the output."""
    import torch

    width, height = hr_size
    _, out_h, out_w, _ = graph.tensors[graph.outputs[0]].shape
    examples = []
    for name in graph.inputs:
        n, in_h, in_w, c = graph.tensors[name].shape
        if (width * in_w) % out_w or (height * in_h) % out_h:
            raise ValueError(f"input {name} ({in_w}x{in_h} for a {out_w}x{out_h} output) has no whole size at {width}x{height}")
        examples.append(torch.zeros(n, c, height * in_h // out_h, width * in_w // out_w))
    return examples


def quantize_at(model, name: str, data: Path | None, hr_size: tuple[int, int], method: str, progress: bool,
                jitter: str | None = None) -> NpuArtifacts:
    """Quantize the model's NPU stage (defaults of ``mnss-kit quantize``) and write its files for ``hr_size``.

    ``data``: dataset directory for calibration; None renders the quantize stage's default
    calibration data at the model's scale with the ``jitter`` pattern it runs with.
    """
    import tempfile

    from ..quantize import run as quantize_run
    from ..quantize.onnx_writer import to_onnx
    from ..quantize.stage import QuantizeOptions, quantize_module
    from ..quantize.tflite_writer import to_tflite

    with tempfile.TemporaryDirectory(prefix="mnss-export-calibration-") as tmp:
        root = Path(data) if data else quantize_run.render_calibration_data(Path(tmp), progress, with_reference=False,
                                                                            scale=model.scale, jitter=jitter)
        sequences = quantize_run.open_data(root, model.scale, family=family_of(model))
        samples_wanted = quantize_run.CALIBRATION_SAMPLES
        log.info("recording %d NPU-stage inputs from recurrent runs on %s", samples_wanted, root)
        samples = quantize_run.calibration_samples(model, sequences, samples_wanted, progress=progress)
    art = quantize_module(npu_module(model), samples, QuantizeOptions(method=method), name=name)
    graph = retarget(art.graph, npu_module(model), hr_size, npu_input_shapes(model, hr_size))
    calibrated_at = list(art.graph.tensors[art.graph.outputs[0]].shape[1:3][::-1])  # the HR size, as the bundle
    report = art.report
    quantization = {
        "source": "checkpoint",
        "method": method,
        "calibration_samples": len(samples),
        "calibration_data": str(data) if data else f"rendered mnss_kit/configs/data/{quantize_run.DEFAULT_DATA_CONFIG}.yaml",
        "calibrated_at_size": calibrated_at,
        **report_summary(report),
    }
    return NpuArtifacts(to_tflite(graph), to_onnx(graph).SerializeToString(), quantization)


def load_quantized_dir(directory: Path) -> tuple[NpuArtifacts, dict]:
    """The files of an ``mnss-kit quantize`` output directory, and its ``report.json``.

    Every file the directory must hold is read and parsed here, so a missing, corrupt or foreign
    one is refused with its name before any work: both NPU files, ``encodings.json``, and a
    ``report.json`` that records the checkpoint's SHA-256.
    """
    from .check import tflite_vs_onnx
    from .npu_files import read_onnx, read_tflite

    missing = [n for n in QUANTIZED_DIR_FILES if not (directory / n).is_file()]
    if missing:
        raise UserError(f"{directory}: not a complete mnss-kit quantize directory (missing {', '.join(missing)})")
    report = _read_json_object(directory / "report.json")
    _read_json_object(directory / "encodings.json")
    if not isinstance(report.get("checkpoint"), dict) or not report["checkpoint"].get("sha256"):
        raise UserError(f"{directory / 'report.json'}: no 'checkpoint.sha256' (written by an older mnss-kit); "
                        "run mnss-kit quantize again")
    tflite_bytes, onnx_bytes = (directory / "npu.tflite").read_bytes(), (directory / "npu_qdq.onnx").read_bytes()
    tflite = read_tflite(tflite_bytes, str(directory / "npu.tflite"))
    onnx = read_onnx(onnx_bytes, str(directory / "npu_qdq.onnx"))
    problems = tflite_vs_onnx(tflite, onnx, "npu.tflite", "npu_qdq.onnx")
    if problems:
        raise UserError(str(directory / problems[0]))  # the line starts with the file's name
    quantization = {
        "source": "directory",
        "directory": str(directory),
        "method": report.get("method"),
        "calibration_samples": report.get("samples"),
        "calibration_data": report.get("data"),
        **report_summary(report),
    }
    return NpuArtifacts(tflite_bytes, onnx_bytes, quantization), report


def _read_json_object(path: Path) -> dict:
    data = read_json(path)
    if not isinstance(data, dict):
        raise UserError(f"{path}: not a JSON object")
    return data


def report_summary(report: dict) -> dict:
    """The quantize report's headline numbers, as finite JSON numbers (None where absent)."""
    agreement = report.get("agreement") or {}
    return {
        "int16_tensors": [str(n) for n in report.get("int16") or []],
        "output_psnr_db_vs_float": {str(k): _number((v or {}).get("psnr_db")) for k, v in (report.get("output") or {}).items()},
        "runtime_agreement_lsb": {str(k): _number(v) for k, v in agreement.items() if not isinstance(v, (dict, list))},
    }


def _number(value) -> int | float | None:
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return int(value)
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None
