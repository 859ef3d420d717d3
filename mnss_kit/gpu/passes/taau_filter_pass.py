"""taau_filter_pass (ntaau): the display: this frame's blend through the steered 3x3 filter (faded
by ``ops.taau.filter_gain`` where the history was resampled), plus the correction."""

from __future__ import annotations

import numpy as np

from ...ops import taau
from ...ops.int8 import quantize as quant
from ...ops.sanitize import sanitize_motion
from ..storage import encode_unorm8, to_half
from .record import DISPLAY_FORMAT, HISTORY_FORMAT, Call, Pass, buffer, image, sampler


def reference(c: Call) -> dict:
    """npu_output (1,H,W,8) int8 raw steering, history (H,W,4) this frame's blend, motion (h,w,2) ->
    display (H,W,3) uint8 codes."""
    r, u = c.read, c.u
    raw = quant.dequantize(np.asarray(r["npu_output"], np.int8), u("u_q_scale"), u("u_q_zero_point"))[0]
    gain = taau.filter_gain(sanitize_motion(r["motion"]), u("u_scale"), u("u_filter_falloff"))
    steer = taau.steer_from_raw(raw, u("u_correction_bound"), 0.0, u("u_filter_bound"), filter_scale=gain)
    return {"display": encode_unorm8(taau.display(to_half(r["history"])[..., :3], steer))}


def outputs(c: Call) -> dict:
    _, hh, hw, _ = c.read["npu_output"].shape
    return {"display": (hh, hw, 3)}


ORDER = 330  # ntaau, last: the display

PASS = Pass(
    "taau_filter_pass", (8, 8, 1), "hr",
    (buffer("npu_output", 0, "uint[]", dtype="int8"), sampler("history", 0, HISTORY_FORMAT), sampler("motion", 1, "rg32f"),
     image("display", 0, DISPLAY_FORMAT)),
    ("u_scale", "u_q_scale", "u_q_zero_point", "u_correction_bound", "u_filter_bound", "u_filter_falloff"),
    exact=False, reference=reference, outputs=outputs,
)
