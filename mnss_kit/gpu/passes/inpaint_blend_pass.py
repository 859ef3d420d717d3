"""inpaint_blend_pass: the rectified history I_R, the warped history blended with the jittered
upsampled colour I_U by the upsampled inpainting weights (``ops.inpaint.rectify``); I_U on a reset."""

from __future__ import annotations

import numpy as np

from ...ops import inpaint, subpixel
from ...ops.sanitize import sanitize_colour
from ..storage import to_half
from .record import Call, Pass, image, sampler

WEIGHT_UPSAMPLE_CODES = {"bilinear": 0, "nearest": 1}  # u_weight_upsample, as inpaint.glsl defines it
WEIGHT_UPSAMPLES = {v: k for k, v in WEIGHT_UPSAMPLE_CODES.items()}


def reference(c: Call) -> dict:
    """-> rectified (H,W,3) fp16 values; on a reset I_U (``warped`` and ``lr_weight`` are not read)."""
    r, scale = c.read, c.u("u_scale")
    upsampled = subpixel.jittered_upsample(sanitize_colour(to_half(r["color"])), c.offset, scale)
    if c.u("u_reset"):
        return {"rectified": to_half(upsampled)}
    mode = WEIGHT_UPSAMPLES[c.u("u_weight_upsample")]
    weight = inpaint.weight_map(np.asarray(r["lr_weight"], np.float32), c.offset, scale, mode)
    return {"rectified": to_half(inpaint.rectify(upsampled, to_half(r["warped"]), weight))}


def outputs(c: Call) -> dict:
    h, w = c.read["color"].shape[:2]
    s = c.u("u_scale")
    return {"rectified": (h * s, w * s, 3)}


ORDER = 120  # MNSS, after inpaint_weights_pass: blends by its weights

PASS = Pass(
    "inpaint_blend_pass", (8, 8, 1), "hr",
    (sampler("color", 0, "rgba16f"), sampler("warped", 1, "rgba16f"), sampler("lr_weight", 2, "r32f"),
     image("rectified", 0, "rgba16f")),
    ("u_scale", "u_jitter", "u_subpixel", "u_weight_upsample", "u_reset"),
    reference=reference, outputs=outputs,
)
