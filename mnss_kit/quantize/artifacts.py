"""What ``mnss-kit quantize`` writes beside the models: encodings JSON, report.json and report.md.

``encodings.json`` lists every tensor's integer encoding, copied from the
graph: activations (scale, zero point, bitwidth, dtype, the representable
real min/max and the calibrated min/max, layout NHWC) and parameters
(per-channel scales of weights and biases).  ``report.json`` holds the
measurements; ``report.md`` is rendered from it, no number typed by hand.
"""

from __future__ import annotations

import math

import numpy as np

from ..ops.int8.ranges import qrange
from .graph import Graph

ENCODINGS_VERSION = 1


def encodings(graph: Graph) -> dict:
    """Plain-data encodings of every quantized tensor of ``graph``."""
    acts = {}
    for name in graph.activations():
        t = graph.tensors[name]
        qmin, qmax = qrange(t.dtype)
        acts[name] = {
            "dtype": t.dtype,
            "bitwidth": np.dtype(t.dtype).itemsize * 8,
            "scale": float(t.scale),
            "zero_point": int(t.zero_point),
            "is_symmetric": t.dtype == "int16",
            "min": float(np.float32(t.scale) * (qmin - t.zero_point)),
            "max": float(np.float32(t.scale) * (qmax - t.zero_point)),
            "calibrated_min": t.rmin,
            "calibrated_max": t.rmax,
            "shape_nhwc": list(t.shape),
            "channel_order": None if t.channel_order is None else [int(c) for c in t.channel_order],
        }
    params = {}
    for name in graph.constants():
        t = graph.tensors[name]
        if t.scale is None:
            continue
        params[name] = {
            "dtype": t.dtype,
            "bitwidth": np.dtype(t.dtype).itemsize * 8,
            "axis": int(t.axis) if t.per_channel else None,
            "scale": np.atleast_1d(np.asarray(t.scale, np.float64)).tolist(),
            "zero_point": np.atleast_1d(np.asarray(t.zero_point, np.int64)).tolist(),
            "is_symmetric": True,
            "shape": list(t.shape),
        }
    return {
        "version": ENCODINGS_VERSION,
        "layout": "NHWC",
        "inputs": list(graph.inputs),
        "outputs": list(graph.outputs),
        "activation_encodings": acts,
        "param_encodings": params,
    }


def _fmt(v, digits: int = 2, signed: bool = False) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        if math.isinf(v):
            return "inf"
        return f"{v:+.{digits}f}" if signed else f"{v:.{digits}f}"
    return str(v)


def summary_table(report: dict) -> str:
    """Plain-text table of the per-tensor results (for the terminal)."""
    rows = [("tensor", "op", "dtype", "scale", "zp", "SQNR dB", "only-this PSNR dB")]
    for t in report["tensors"]:
        rows.append((t["name"], t["op"], t["dtype"], f"{t['scale']:.3g}", str(t["zero_point"]), _fmt(t.get("sqnr_db")), _fmt(t.get("only_psnr_db"))))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


QUALITY_COLUMNS = (("psnr", "PSNR dB", 3), ("ssim", "SSIM", 5), ("if_ssim", "IF-SSIM", 5))


def comparison_table(report: dict) -> str:
    """Plain-text fp32 / int8 / delta table, overall and per sequence (``report`` as from ``fp32_vs_int8``)."""
    rows = [("sequence", "frames", "") + tuple(c[1] for c in QUALITY_COLUMNS)]
    parts = [(p["sequence"], str(p["frames"]), p) for p in report.get("sequences", [])]
    parts.append(("all", str(report.get("evaluation", {}).get("frames", "")), report))
    for label, frames, scores in parts:
        for i, kind in enumerate(("fp32", "int8", "delta")):
            cells = tuple(_fmt(scores[kind][key], digits, signed=kind == "delta") for key, _, digits in QUALITY_COLUMNS)
            rows.append((label if i == 0 else "", frames if i == 0 else "", kind) + cells)
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def evaluation_sentence(info: dict) -> str:
    """One sentence on what the fp32-vs-int8 numbers were measured on and with."""
    frames = "all frames" if info["max_frames_per_sequence"] is None else f"at most {info['max_frames_per_sequence']} frames"
    where = "held-out data" if info["held_out"] else "the calibration data (not held out: pass --eval-data for a held-out set)"
    return (f"{info['evaluator']}; {info['sequences']} sequences of {info['data']} ({where}), {frames} per sequence, "
            f"{info['frames']} frames in all.  GPU part: {info['gpu_part']}.  int8 NPU stage: npu.tflite in {info['int8_runtime']}.  "
            f"delta = int8 - fp32.")


def agreement_sentence(agree: dict) -> str:
    """LiteRT vs ONNX Runtime agreement (``stage.runtime_agreement``) in one paragraph."""
    return (f"LiteRT vs ONNX Runtime QDQ, same scales and zero points by construction.  Each op alone on the same inputs "
            f"(LiteRT reference kernels): at most {agree['per_op_max_lsb']} LSB.  Whole graph, every int8 tensor: LiteRT "
            f"XNNPACK (default CPU path) at most {agree['end_to_end_max_lsb_xnnpack']} LSB "
            f"({agree['end_to_end_fraction_differing_xnnpack']:.4%} of values differ); LiteRT reference kernels at most "
            f"{agree['end_to_end_max_lsb']} LSB ({agree['end_to_end_fraction_differing']:.4%}), where their two roundings "
            "(Q31 high multiply, then rounding shift) part from ONNX Runtime's single float32 rounding near ties and "
            "the differences grow downstream.")


def report_markdown(report: dict) -> str:
    """``report.md`` from ``report.json``'s content."""
    out = [f"# int8 NPU stage: {report['model']}", ""]
    out.append(f"Calibration: {report['method']} on {report['samples']} recorded stage inputs ({report['data']}).")
    if report.get("int16"):
        out.append(f"16-bit activations (A16W8): {', '.join(report['int16'])}.")
    if report.get("qat"):
        q = report["qat"]
        out.append(f"QAT: {q['steps']} steps, distillation loss (mean of the first / last tenth of steps) {q['loss_first']:.3g} -> {q['loss_last']:.3g}.")
    out += ["", "## Output", "", "| runtime | PSNR vs float stage (dB) | SQNR (dB) |", "|---|---|---|"]
    for name, m in report["output"].items():
        out.append(f"| {name} | {_fmt(m['psnr_db'])} | {_fmt(m['sqnr_db'])} |")
    out += ["", agreement_sentence(report["agreement"]), ""]
    if report.get("delta"):
        out += ["## fp32 vs int8, recurrent pipeline", "", evaluation_sentence(report["evaluation"]), "",
                "```", comparison_table(report), "```", ""]
    out += ["## Tensors", "", "SQNR: each tensor of the final graph against the float model. Only-this PSNR: output PSNR with only that "
            "tensor quantized, measured on the all-int8 graph (what chooses the 16-bit tensors).", "", "```", summary_table(report), "```", ""]
    out += ["## Files", "", "| file | bytes |", "|---|---|"]
    out += [f"| {k} | {v} |" for k, v in report["files"].items()]
    return "\n".join(out) + "\n"
