"""taau_lr_pack_pass (ntaau_lr): the NPU input at LR, padded to even sizes
(``ops.taau_lr.steering_features``), int8; with ``u_detail`` 1 the detail branch's s x s channels follow."""

from __future__ import annotations

import numpy as np

from ...ops import taau_lr
from ...ops.int8 import quantize as quant
from ...ops.sanitize import sanitize_colour
from ..storage import to_half
from .record import Call, Pass, buffer, sampler


def reference(c: Call) -> dict:
    """color (h,w,3), reprojected (H,W,4), evidence (h,w,4) -> npu_input (1,h',w',C) int8, h' and
    w' even, quantized as ``ops.int8.quantize.quantize`` under the profile: C = 8, plus 1 with a
    scale input (``u_scale_input`` != 0), plus s * s with ``u_detail`` 1 (integer scales).  On a
    reset the history is zero (colour and weight), as the model's state after a cut; ``reprojected``
    is not read."""
    e = np.asarray(c.read["evidence"], np.float32)
    hr_shape = np.asarray(c.read["reprojected"]).shape[:2]  # the HR size at any scale (u_scale 0: a fractional one)
    r = np.zeros((*hr_shape, 4), np.float32) if c.u("u_reset") else to_half(c.read["reprojected"])
    features = taau_lr.steering_features(sanitize_colour(to_half(c.read["color"])), r[..., :3], r[..., 3:], e[..., 0:1],
                                         e[..., 1:2], c.u("u_scale"), c.u("u_max_weight"),
                                         float(np.float32(c.uniforms.get("u_scale_input", 0.0))),
                                         bool(c.uniforms.get("u_detail", 0)))
    return {"npu_input": quant.quantize(features, c.u("u_q_scale"), c.u("u_q_zero_point"), "int8", c.profile)[None]}


def channels(u: dict) -> int:
    """The NPU input's channels under the pass's uniforms ``u`` (name -> value)."""
    detail = int(u["u_scale"]) ** 2 if u.get("u_detail", 0) else 0
    return 8 + (1 if u.get("u_scale_input", 0.0) else 0) + detail


def outputs(c: Call) -> dict:
    h, w = c.read["color"].shape[:2]
    return {"npu_input": (1, h + h % 2, w + w % 2, channels(c.uniforms))}


ORDER = 420  # ntaau_lr, after the evidence: packs the NPU input (the NPU runs next)

PASS = Pass(
    "taau_lr_pack_pass", (64, 1, 1), "words",
    (sampler("color", 0, "rgba16f"), sampler("reprojected", 1, "rgba16f"), sampler("evidence", 2, "rgba32f"),
     buffer("npu_input", 0, "uint[]", "write", "int8")),
    ("u_scale", "u_reset", "u_max_weight", "u_word_count", "u_q_scale", "u_q_reciprocal", "u_q_use_reciprocal", "u_q_rounding",
     "u_q_zero_point", "u_scale_input", "u_detail"),
    exact=False, reference=reference, outputs=outputs,
)
