"""Quantize one float NPU module: trace, calibrate, quantize, (A16, QAT), write and measure.

``quantize_module`` is the core of the stage; its entry function (:func:`.run.quantize`,
``mnss-kit quantize``) wraps it with checkpoint loading and calibration data.  Written into ``out_dir``:

    npu.tflite      int8 (NHWC, integer I/O), LiteRT flatbuffer
    npu_qdq.onnx    the same graph as QDQ ONNX (NCHW, integer I/O), same scales and zero points
    encodings.json  every tensor's encoding (see :mod:`.artifacts`)
    report.json     measurements; report.md renders it
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path
from typing import Sequence

import numpy as np
import torch

from ..fileio import json_text
from ..metrics.psnr import psnr
from . import artifacts
from .calibrate import calibrate
from .graph import Graph, op_graph, prefix_graph
from .onnx_writer import to_onnx
from .params import quantize_graph
from ..ops.runtimes import RUNTIMES
from .runtime import OnnxRunner, TfliteRunner, dequantize_tensor, open_runner, quantize_inputs
from .sensitivity import choose_int16, only_layer_psnr, sqnr_db, tensor_sqnr
from .tflite_writer import to_tflite
from .trace import trace

log = logging.getLogger(__name__)
MAX_EVAL_SAMPLES = 8  # sensitivity and agreement are measured on at most this many samples


@dataclasses.dataclass
class QuantizeOptions:
    method: str = "minmax"
    int16: int = 0  # number of most sensitive tensors given 16-bit activations
    qat_steps: int = 0
    qat_lr: float = 1e-4


@dataclasses.dataclass
class QuantizedArtifacts:
    graph: Graph
    tflite: bytes
    onnx: bytes
    report: dict


def quantize_module(module: torch.nn.Module, samples: Sequence[Sequence[np.ndarray]], options: QuantizeOptions, name: str = "model") -> QuantizedArtifacts:
    """Quantize ``module`` (float, NCHW) calibrated on ``samples`` (lists of NCHW float32 inputs, batch 1)."""
    module = module.eval()
    example = [torch.from_numpy(np.asarray(x, np.float32)) for x in samples[0]]
    float_graph = trace(module, example)
    log.info("traced %d ops; calibrating (%s) on %d samples", len(float_graph.ops), options.method, len(samples))
    ranges = calibrate(float_graph, samples, options.method)
    graph = quantize_graph(float_graph, ranges)
    evals = list(samples[:MAX_EVAL_SAMPLES])
    _, float_outputs = tensor_sqnr(float_graph, graph, to_tflite(graph), evals)
    only_psnr = only_layer_psnr(graph, evals, float_outputs)
    chosen, skipped = [], {}
    if options.int16:
        chosen, skipped = choose_int16(graph, only_psnr, options.int16)
        graph = quantize_graph(float_graph, ranges, int16=set(chosen))
    qat = None
    if options.qat_steps:
        from .fakequant import finetune

        graph, losses = finetune(graph, module, samples, steps=options.qat_steps, lr=options.qat_lr)
        tenth = max(1, len(losses) // 10)  # single-sample losses are noisy: average the first and last tenth
        qat = {"steps": options.qat_steps, "lr": options.qat_lr, "loss_first": float(np.mean(losses[:tenth])), "loss_last": float(np.mean(losses[-tenth:]))}
    tflite = to_tflite(graph)
    onnx_bytes = to_onnx(graph).SerializeToString()
    sqnr, _ = tensor_sqnr(float_graph, graph, tflite, evals)
    report = {
        "model": name,
        "method": options.method,
        "samples": len(samples),
        "int16": chosen,
        "int16_skipped": skipped,
        "qat": qat,
        "layout": {"npu.tflite": "NHWC", "npu_qdq.onnx": "NCHW"},
        "inputs": {n: _io(graph, n) for n in graph.inputs},
        "outputs": {n: _io(graph, n) for n in graph.outputs},
        "output": output_quality(graph, tflite, onnx_bytes, evals, float_outputs),
        "agreement": runtime_agreement(graph, tflite, evals),
        "tensors": _tensor_rows(graph, sqnr, only_psnr),
    }
    return QuantizedArtifacts(graph, tflite, onnx_bytes, report)


def write_artifacts(art: QuantizedArtifacts, out_dir: str | Path) -> dict[str, int]:
    """Write the four files into ``out_dir`` (a staging directory); returns their sizes in bytes."""
    out = Path(out_dir)
    (out / "npu.tflite").write_bytes(art.tflite)
    (out / "npu_qdq.onnx").write_bytes(art.onnx)
    (out / "encodings.json").write_text(json_text(artifacts.encodings(art.graph)))
    files = {n: (out / n).stat().st_size for n in ("npu.tflite", "npu_qdq.onnx", "encodings.json")}
    art.report["files"] = files
    (out / "report.json").write_text(json_text(art.report))
    (out / "report.md").write_text(artifacts.report_markdown(art.report))
    return files


def output_quality(graph: Graph, tflite: bytes, onnx_bytes: bytes, samples, float_outputs) -> dict[str, dict]:
    """Output PSNR (peak 1) and SQNR of each runtime's dequantized output against the float graph."""
    out = graph.outputs[0]
    ref = np.concatenate([f[out] for f in float_outputs])
    result = {}
    for name in RUNTIMES:
        runner = open_runner(name, tflite, onnx_bytes)
        got = np.concatenate([dequantize_tensor(graph, out, runner.run(quantize_inputs(graph, list(s), name))[out]) for s in samples])
        result[name] = {"psnr_db": psnr(got, ref), "sqnr_db": sqnr_db(ref, got)}
    return result


def runtime_agreement(graph: Graph, tflite: bytes, samples) -> dict:
    """How far LiteRT and ONNX Runtime QDQ results are apart, in LSB of each tensor's own type.

    ``per_op``: each op run alone in LiteRT reference kernels on the same integer
    inputs as ONNX Runtime (what the two files and their kernels contribute).
    ``whole_graph``: both runtimes run the whole graph from the same inputs, so a
    1-LSB difference can grow downstream; per LiteRT kernel set, every tensor's
    largest difference.  ``tflite-ref`` keeps every intermediate tensor; XNNPACK
    (LiteRT's default CPU path) keeps none, so each tensor is the output of the
    graph prefix producing it.  The flat ``end_to_end_*`` keys summarise the int8
    tensors of each.
    """
    names = [op.outputs[0] for op in graph.ops]  # the graph inputs are the same integers in both by construction
    ort_runner = OnnxRunner(to_onnx(graph, expose=names))
    reference = TfliteRunner(tflite, "tflite-ref", preserve_all=True)
    prefixes = {n: TfliteRunner(to_tflite(prefix_graph(graph, n)), "xnnpack") for n in names}
    worst = {k: dict.fromkeys(names, 0) for k in ("tflite-ref", "xnnpack")}
    differing = dict.fromkeys(worst, 0)
    total = 0
    per_op = {}
    for i, s in enumerate(samples):
        q = quantize_inputs(graph, list(s))
        ort = {**dict(zip(graph.inputs, q)), **ort_runner.run(q)}
        runs = {"tflite-ref": reference.run(q, names), "xnnpack": {n: prefixes[n].run(q)[n] for n in names}}
        for kernels, got in runs.items():
            for n in names:
                d = _lsb(got[n], ort[n])
                worst[kernels][n] = max(worst[kernels][n], int(d.max()))
                differing[kernels] += int(np.count_nonzero(d))
        total += sum(ort[n].size for n in names)
        if i == 0:
            for op in graph.ops:
                sub = op_graph(graph, op)
                inputs = [ort[n] for n in sub.inputs]
                alone = TfliteRunner(to_tflite(sub), "tflite-ref").run(inputs)[op.outputs[0]]
                per_op[op.outputs[0]] = int(_lsb(alone, OnnxRunner(to_onnx(sub)).run(inputs)[op.outputs[0]]).max())
    int8 = [n for n in names if graph.tensors[n].dtype == "int8"]
    int16 = [n for n in names if graph.tensors[n].dtype == "int16"]
    summary = {"per_op_max_lsb": max(per_op.values())}
    for kernels, suffix in (("tflite-ref", ""), ("xnnpack", "_xnnpack")):
        summary[f"end_to_end_max_lsb{suffix}"] = max((worst[kernels][n] for n in int8), default=0)
        summary[f"end_to_end_max_lsb_int16{suffix}"] = max((worst[kernels][n] for n in int16), default=0)
        summary[f"end_to_end_fraction_differing{suffix}"] = differing[kernels] / max(total, 1)
    return {**summary, "per_op": per_op, "whole_graph": worst}


def _lsb(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a.astype(np.int64) - b.astype(np.int64))


def _io(graph: Graph, name: str) -> dict:
    t = graph.tensors[name]
    n, h, w, c = t.shape
    return {"shape_nhwc": [n, h, w, c], "dtype": t.dtype, "scale": float(t.scale), "zero_point": int(t.zero_point)}


def _tensor_rows(graph: Graph, sqnr: dict, only_psnr: dict) -> list[dict]:
    rows = []
    for name in graph.activations():
        t = graph.tensors[name]
        op = graph.producer(name)
        rows.append(
            {
                "name": name,
                "op": op.kind if op else "INPUT",
                "dtype": t.dtype,
                "scale": float(t.scale),
                "zero_point": int(t.zero_point),
                "calibrated_min": t.rmin,
                "calibrated_max": t.rmax,
                "sqnr_db": sqnr.get(name),
                "only_psnr_db": only_psnr.get(name),
            }
        )
    return rows
