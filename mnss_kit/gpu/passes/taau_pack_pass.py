"""taau_pack_pass (ntaau): the NPU input at LR: the colour, then the clamped history, its weight /
``u_max_weight`` and the clamp distance pixel-unshuffled (``ops.taau.steering_features``), int8."""

from __future__ import annotations

from ...ops import taau
from ...ops.int8 import quantize as quant
from ...ops.sanitize import sanitize_colour
from ..storage import to_half
from .record import Call, Pass, buffer, sampler


def reference(c: Call) -> dict:
    """color (h,w,3), reprojected (H,W,4) -> npu_input (1,h,w,3 + 5 s^2) int8, quantized as
    ``ops.int8.quantize.quantize`` under the profile."""
    r = to_half(c.read["reprojected"])
    features = taau.steering_features(sanitize_colour(to_half(c.read["color"])), r[..., :3], r[..., 3:], c.u("u_scale"),
                                      c.u("u_max_weight"))
    return {"npu_input": quant.quantize(features, c.u("u_q_scale"), c.u("u_q_zero_point"), "int8", c.profile)[None]}


def outputs(c: Call) -> dict:
    s = c.u("u_scale")
    return {"npu_input": (1, *c.read["color"].shape[:2], 3 + 5 * s * s)}


ORDER = 310  # ntaau, after taau_reproject_pass: packs the NPU input (the NPU runs next)

PASS = Pass(
    "taau_pack_pass", (64, 1, 1), "words",
    (sampler("color", 0, "rgba16f"), sampler("reprojected", 1, "rgba16f"), buffer("npu_input", 0, "uint[]", "write", "int8")),
    ("u_scale", "u_max_weight", "u_word_count", "u_q_scale", "u_q_reciprocal", "u_q_use_reciprocal", "u_q_rounding",
     "u_q_zero_point"),
    exact=False, reference=reference, outputs=outputs,
)
