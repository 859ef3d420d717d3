"""taau_lr_filter_pass (ntaau_lr): the display: this frame's blend through the filter steered from
LR (``ops.taau_lr.filter_weights``), plus the detail patch in a model with a detail branch."""

from __future__ import annotations

import numpy as np

from ...ops import taau, taau_lr
from ...ops.int8 import quantize as quant
from ...ops.taau_lr import STEER_CHANNELS
from ..storage import encode_unorm8, to_half
from .record import DISPLAY_FORMAT, HISTORY_FORMAT, Call, Pass, buffer, image, sampler


def reference(c: Call) -> dict:
    """npu_output (1,h',w',6 + ``u_detail_channels``) int8 raw LR steering (and detail patch),
    history (H,W,4) this frame's blend -> display (H,W,3) uint8 codes, plus the detail patch
    (``ops.taau_lr.detail_luma``) when ``u_detail_bound`` > 0.  The LR size is the history's over
    ``u_scale``, or at a fractional scale (``u_scale`` 0) ``u_lr_size`` ``(w, h)``."""
    history, scale = c.read["history"], c.u("u_scale")
    if scale:
        h, w = history.shape[0] // scale, history.shape[1] // scale
    else:
        w, h = (int(v) for v in c.u("u_lr_size"))
    raw = quant.dequantize(np.asarray(c.read["npu_output"], np.int8), c.u("u_q_scale"), c.u("u_q_zero_point"))[0, :h, :w]
    axis, diagonal = taau_lr.filter_weights(raw, scale, c.u("u_filter_bound"), (history.shape[1], history.shape[0]))
    steer = taau.Steer(filter_axis=axis, filter_diagonal=diagonal)
    if c.uniforms.get("u_detail_bound", 0.0) > 0:
        steer.correction = taau_lr.detail_correction(raw[..., STEER_CHANNELS:], history.shape[:2], c.u("u_detail_bound"))
    return {"display": encode_unorm8(taau.display(to_half(history)[..., :3], steer))}


def outputs(c: Call) -> dict:
    return {"display": (*c.read["history"].shape[:2], 3)}


ORDER = 440  # ntaau_lr, last: the display

PASS = Pass(
    "taau_lr_filter_pass", (8, 8, 1), "hr",
    (buffer("npu_output", 0, "uint[]", dtype="int8"), sampler("history", 0, HISTORY_FORMAT), image("display", 0, DISPLAY_FORMAT)),
    ("u_scale", "u_lr_size", "u_q_scale", "u_q_zero_point", "u_filter_bound", "u_detail_channels", "u_detail_bound"),
    exact=False, reference=reference, outputs=outputs,
)
