"""taau_lr_accumulate_pass (ntaau_lr): the accumulation of this frame's samples into the
reprojected history, steered from LR (``ops.taau_lr.steer_from_lr``, ``ops.taau.blend``); in a
model with a detail branch and no display filter, the display gets the detail patch here."""

from __future__ import annotations

import numpy as np

from ...ops import taau, taau_lr
from ...ops.int8 import quantize as quant
from ...ops.sanitize import sanitize_colour, sanitize_motion
from ...ops.taau_lr import STEER_CHANNELS
from ..storage import encode_unorm8, to_half
from .record import DISPLAY_FORMAT, HISTORY_FORMAT, Call, Pass, buffer, image, sampler


def reference(c: Call) -> dict:
    """npu_output (1,h',w',6 + ``u_detail_channels``) int8 raw LR steering (and detail patch),
    color (h,w,3), reprojected (H,W,4), evidence (h,w,4), motion (h,w,2; read only for a
    history-gain floor that fades with it) -> history (H,W,4) fp16 values: the blend and its
    weight, display (H,W,3) uint8 codes of the blend, without the display filter, plus the detail
    patch (``ops.taau_lr.detail_luma``) when ``u_detail_bound`` > 0."""
    r, u, scale = c.read, c.u, c.u("u_scale")
    h, w = np.asarray(r["color"]).shape[:2]
    reprojected = np.asarray(r["reprojected"])
    hr_size = (reprojected.shape[1], reprojected.shape[0])  # u_scale 0: the sizes give the ratio
    raw = quant.dequantize(np.asarray(r["npu_output"], np.int8), u("u_q_scale"), u("u_q_zero_point"))[0, :h, :w]
    floor = taau.history_floor(sanitize_motion(r["motion"]), scale, u("u_history_gain_min"), u("u_still_motion_px"), hr_size)
    trust = np.asarray(r["evidence"], np.float32)[..., 2:3]
    steer = taau_lr.steer_from_lr(raw[..., :STEER_CHANNELS], trust, scale, u("u_box_bound"), 0.0, hr_size, floor)
    terms = taau.current_terms(sanitize_colour(to_half(r["color"])), c.offset, scale, u("u_sample_sigma"), hr_size)
    history = to_half(reprojected)
    _, blend, weight = taau.blend(*terms, history[..., :3], history[..., 3:], u("u_prior_weight"), u("u_max_weight"), steer)
    shown = blend
    if c.uniforms.get("u_detail_bound", 0.0) > 0:
        correction = taau_lr.detail_correction(raw[..., STEER_CHANNELS:], blend.shape[:2], u("u_detail_bound"))
        shown = taau.display(blend, taau.Steer(correction=correction))
    return {"history": to_half(np.concatenate([blend, weight], axis=-1)), "display": encode_unorm8(shown)}


def outputs(c: Call) -> dict:
    hh, hw = c.read["reprojected"].shape[:2]  # the HR size at any scale (u_scale 0: a fractional one)
    return {"history": (hh, hw, 4), "display": (hh, hw, 3)}


ORDER = 430  # ntaau_lr, after the NPU: the accumulation steered from LR

PASS = Pass(
    "taau_lr_accumulate_pass", (8, 8, 1), "hr",
    (buffer("npu_output", 0, "uint[]", dtype="int8"), sampler("color", 0, "rgba16f"), sampler("reprojected", 1, "rgba16f"),
     sampler("evidence", 2, "rgba32f"), sampler("motion", 3, "rg32f"), image("history", 0, HISTORY_FORMAT),
     image("display", 1, DISPLAY_FORMAT)),
    ("u_scale", "u_jitter", "u_q_scale", "u_q_zero_point", "u_box_bound", "u_history_gain_min", "u_still_motion_px",
     "u_sample_sigma", "u_prior_weight", "u_max_weight", "u_detail_channels", "u_detail_bound"),
    exact=False, reference=reference, outputs=outputs,
)
