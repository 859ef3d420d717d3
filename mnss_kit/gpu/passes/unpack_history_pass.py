"""unpack_history_pass: the NPU's int8 output dequantized into the history and the display."""

from __future__ import annotations

import numpy as np

from ...ops.int8 import quantize as quant
from ..storage import encode_unorm8, to_half
from .record import DISPLAY_FORMAT, HISTORY_FORMAT, Call, Pass, buffer, image


def reference(c: Call) -> dict:
    """npu_output int8 (1,H,W,3) -> history (H,W,3) fp16 values, display (H,W,3) uint8."""
    v = quant.dequantize(np.asarray(c.read["npu_output"])[0], c.u("u_q_scale"), c.u("u_q_zero_point"))
    return {"history": to_half(v), "display": encode_unorm8(v)}


def outputs(c: Call) -> dict:
    _, hh, hw, _ = c.read["npu_output"].shape
    return {"history": (hh, hw, 3), "display": (hh, hw, 3)}


ORDER = 160  # MNSS, after the NPU: its output into the history and display

PASS = Pass(
    "unpack_history_pass", (8, 8, 1), "hr",
    (buffer("npu_output", 0, "uint[]", dtype="int8"), image("history", 0, HISTORY_FORMAT), image("display", 1, DISPLAY_FORMAT)),
    ("u_q_scale", "u_q_zero_point"),
    reference=reference, outputs=outputs,
)
