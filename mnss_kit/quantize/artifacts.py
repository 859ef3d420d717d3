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

from ..ops import quant as Q
from .graph import Graph

ENCODINGS_VERSION = 1


def encodings(graph: Graph) -> dict:
    """Plain-data encodings of every quantized tensor of ``graph``."""
    acts = {}
    for name in graph.activations():
        t = graph.tensors[name]
        qmin, qmax = Q.qrange(t.dtype)
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


def _fmt(v, digits: int = 2) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        if math.isinf(v):
            return "inf"
        return f"{v:.{digits}f}"
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
    agree = report["agreement"]
    out += ["", f"LiteRT reference vs ONNX Runtime QDQ, same scales and zero points by construction: each op alone on the same "
            f"inputs differs by at most {agree['per_op_max_lsb']} LSB; whole-graph runs by at most {agree['end_to_end_max_lsb']} LSB "
            f"on int8 tensors ({agree['end_to_end_fraction_differing']:.3%} of values differ).", ""]
    if report.get("pipeline"):
        out += ["## Recurrent pipeline (history from the model's own output)", "",
                "| sequence | frames | int8 runtime | float PSNR vs reference (dB) | int8 PSNR vs reference (dB) |", "|---|---|---|---|---|"]
        for p in report["pipeline"]:
            out.append(f"| {p['sequence']} | {p['frames']} | {p['runtime']} | {_fmt(p['float_psnr_db'])} | {_fmt(p['int8_psnr_db'])} |")
        out.append("")
    out += ["## Tensors", "", "SQNR: each tensor of the final graph against the float model. Only-this PSNR: output PSNR with only that "
            "tensor quantized, measured on the all-int8 graph (what chooses the 16-bit tensors).", "", "```", summary_table(report), "```", ""]
    out += ["## Files", "", "| file | bytes |", "|---|---|"]
    out += [f"| {k} | {v} |" for k, v in report["files"].items()]
    return "\n".join(out) + "\n"
