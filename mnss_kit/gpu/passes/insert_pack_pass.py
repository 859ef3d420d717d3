"""insert_pack_pass: the AA net's output inserted into the rectified history at this frame's
sampled sub-pixels (``ops.subpixel.insert_valid_samples``: not where the AA pass wrote
``ops.sanitize.NO_SAMPLE``), quantized to the int8 NPU input."""

from __future__ import annotations

from ...ops import subpixel
from ...ops.int8 import quantize as quant
from ..storage import to_half
from .record import Call, Pass, buffer, sampler


def reference(c: Call) -> dict:
    """rectified (H,W,3), aa (h,w,3) -> npu_input (1,H,W,3) int8, ``ops.int8.quantize.quantize`` under the profile."""
    image = subpixel.insert_valid_samples(to_half(c.read["rectified"]), to_half(c.read["aa"]), c.offset, c.u("u_scale"))
    return {"npu_input": quant.quantize(image, c.u("u_q_scale"), c.u("u_q_zero_point"), "int8", c.profile)[None]}


def outputs(c: Call) -> dict:
    return {"npu_input": (1, *c.read["rectified"].shape[:2], 3)}


ORDER = 150  # MNSS, after the AA net: packs the NPU input (the NPU runs next)

PASS = Pass(
    "insert_pack_pass", (64, 1, 1), "words",
    (sampler("rectified", 0, "rgba16f"), sampler("aa", 1, "rgba16f", array=True),
     buffer("npu_input", 0, "uint[]", "write", "int8")),
    ("u_scale", "u_subpixel", "u_word_count", "u_q_scale", "u_q_reciprocal", "u_q_use_reciprocal",
     "u_q_rounding", "u_q_zero_point"),
    reference=reference, outputs=outputs,
)
