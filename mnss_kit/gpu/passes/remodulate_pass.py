"""remodulate_pass (FuseSR): the NPU's int8 residual plus the upsampled L
(``ops.demodulation.add_upsampled``), remodulated by the BRDF, into the history and the display."""

from __future__ import annotations

import numpy as np

from ...ops import demodulation
from ...ops.int8 import quantize as quant
from ..storage import encode_unorm8, to_half
from .record import DISPLAY_FORMAT, HISTORY_FORMAT, Call, Pass, buffer, image, sampler


def reference(c: Call) -> dict:
    """npu_output int8 (1,H,W,3), l (h,w,3) -> history (H,W,3) fp16 values, display (H,W,3) uint8
    (the HR L itself with ``u_demodulate`` 0: ``fbeta`` and ``emissive`` are not read)."""
    r = c.read
    v = quant.dequantize(np.asarray(r["npu_output"])[0], c.u("u_q_scale"), c.u("u_q_zero_point"))
    v = demodulation.add_upsampled(v, to_half(np.asarray(r["l"])[..., :3]), c.u("u_scale"))
    if c.u("u_demodulate"):
        v = demodulation.remodulate(v, to_half(r["fbeta"]), to_half(r["emissive"]))
    return {"history": to_half(v), "display": encode_unorm8(v)}


def outputs(c: Call) -> dict:
    _, hh, hw, _ = c.read["npu_output"].shape
    return {"history": (hh, hw, 3), "display": (hh, hw, 3)}


ORDER = 220  # FuseSR, last, after the NPU: into the history and display

PASS = Pass(
    "remodulate_pass", (8, 8, 1), "hr",
    (buffer("npu_output", 0, "uint[]", dtype="int8"), sampler("fbeta", 0, "rgba16f"), sampler("emissive", 1, "rgba16f"),
     sampler("l", 2, "rgba16f", array=True), image("history", 0, HISTORY_FORMAT), image("display", 1, DISPLAY_FORMAT)),
    ("u_scale", "u_q_scale", "u_q_zero_point", "u_demodulate"),
    exact=False, reference=reference, outputs=outputs,
)
