"""taau_accumulate_pass (ntaau): the steered accumulation of this frame's samples into the
reprojected history (``ops.taau.blend``), steered by the NPU's output."""

from __future__ import annotations

import numpy as np

from ...ops import taau
from ...ops.int8 import quantize as quant
from ...ops.sanitize import sanitize_colour, sanitize_motion
from ..storage import encode_unorm8, to_half
from .record import DISPLAY_FORMAT, HISTORY_FORMAT, Call, Pass, buffer, image, sampler


def reference(c: Call) -> dict:
    """npu_output (1,H,W,6 or 8) int8 raw steering (the first six used), color (h,w,3), reprojected
    (H,W,4), motion (h,w,2) -> history (H,W,4) fp16 values: the uncorrected blend and its weight,
    display (H,W,3) uint8 codes of the corrected output, without the display filter."""
    r, u, scale = c.read, c.u, c.u("u_scale")
    raw = quant.dequantize(np.asarray(r["npu_output"], np.int8), u("u_q_scale"), u("u_q_zero_point"))[0, ..., :6]
    terms = taau.current_terms(sanitize_colour(to_half(r["color"])), c.offset, scale, u("u_sample_sigma"))
    history = to_half(r["reprojected"])
    floor = taau.history_floor(sanitize_motion(r["motion"]), scale, u("u_history_gain_min"), u("u_still_motion_px"))
    steer = taau.steer_from_raw(raw, u("u_correction_bound"), floor, box_bound=u("u_box_bound"))
    output, blend, weight = taau.blend(*terms, history[..., :3], history[..., 3:], u("u_prior_weight"), u("u_max_weight"), steer)
    return {"history": to_half(np.concatenate([blend, weight], axis=-1)), "display": encode_unorm8(output)}


def outputs(c: Call) -> dict:
    _, hh, hw, _ = c.read["npu_output"].shape
    return {"history": (hh, hw, 4), "display": (hh, hw, 3)}


ORDER = 320  # ntaau, after the NPU: the steered accumulation

PASS = Pass(
    "taau_accumulate_pass", (8, 8, 1), "hr",
    (buffer("npu_output", 0, "uint[]", dtype="int8"), sampler("color", 0, "rgba16f"), sampler("reprojected", 1, "rgba16f"),
     sampler("motion", 2, "rg32f"), image("history", 0, HISTORY_FORMAT), image("display", 1, DISPLAY_FORMAT)),
    ("u_scale", "u_steer_channels", "u_jitter", "u_q_scale", "u_q_zero_point", "u_correction_bound", "u_box_bound",
     "u_history_gain_min", "u_still_motion_px", "u_sample_sigma", "u_prior_weight", "u_max_weight"),
    exact=False, reference=reference, outputs=outputs,
)
