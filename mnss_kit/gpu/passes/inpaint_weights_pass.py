"""inpaint_weights_pass: the LR inpainting weights (``ops.inpaint.lr_weights``): a learned 3x3 conv
on the colour, depth and the warped history and depth at this frame's samples, then an activation;
0 where the engine's colour is not finite (no sample: the history is kept, ``ops.sanitize``)."""

from __future__ import annotations

from ...ops import inpaint, subpixel
from ...ops.sanitize import colour_not_finite, sanitize_colour, sanitize_depth
from ..storage import to_half
from .record import Call, Pass, buffer, image, sampler

ACTIVATION_CODES = {"sigmoid": 0, "tanh": 1}  # u_activation, as inpaint_weights.glsl defines it
ACTIVATIONS = {v: k for k, v in ACTIVATION_CODES.items()}


def reference(c: Call) -> dict:
    """-> lr_weight (h,w,1) float32 in [0, 1]."""
    r, scale, conv = c.read, c.u("u_scale"), c.weights["weights"]
    past = subpixel.extract_samples(to_half(r["warped"]), c.offset, scale)
    weight = inpaint.lr_weights(sanitize_colour(to_half(r["color"])), sanitize_depth(r["depth"]), past, r["warped_depth"],
                                conv.weight, conv.bias, ACTIVATIONS[c.u("u_activation")], c.conv,
                                colour_not_finite(r["color"]))
    return {"lr_weight": weight}


def outputs(c: Call) -> dict:
    return {"lr_weight": (*c.read["color"].shape[:2], 1)}


ORDER = 110  # MNSS, after warp_pass: reads the warped history and depth

PASS = Pass(
    "inpaint_weights_pass", (8, 8, 1), "lr",
    (sampler("color", 0, "rgba16f"), sampler("depth", 1, "r32f"), sampler("warped", 2, "rgba16f"),
     sampler("warped_depth", 3, "r32f"), buffer("weights", 0, "vec4[]"), image("lr_weight", 0, "r32f")),
    ("u_scale", "u_subpixel", "u_activation"),
    reference=reference, outputs=outputs,
)
