"""fsr2_reconstruct_pass (fsr2): the depth and motion dilated across edges (``ops.fsr2.dilate``),
and the previous frame's depth reconstructed into an integer buffer
(``ops.fsr2.reconstruct_previous_depth_encoded``, integer atomics on the GPU)."""

from __future__ import annotations

import numpy as np

from ...ops import fsr2
from ...ops.sanitize import sanitize_depth, sanitize_motion
from .fsr2_params import fsr2_params_from_uniforms
from .record import Call, Pass, buffer, image, sampler


def reference(c: Call) -> dict:
    """depth (h,w,1), motion (h,w,2) -> dilated (h,w,4): the nearest neighbour's depth and motion
    across an edge, 0; previous_depth (h*w,) uint32: the encoded depth bits, 0 where no surface
    landed (the buffer starts cleared, as fsr2_accumulate_pass leaves it)."""
    params = fsr2_params_from_uniforms(c.uniforms)
    depth, motion = sanitize_depth(np.asarray(c.read["depth"], np.float32)), sanitize_motion(np.asarray(c.read["motion"], np.float32))
    dilated_depth, dilated_motion = fsr2.dilate(depth, motion, params.dilation_edge)
    encoded = fsr2.reconstruct_previous_depth_encoded(dilated_depth, dilated_motion)
    dilated = np.concatenate([dilated_depth, dilated_motion, np.zeros_like(dilated_depth)], axis=-1)
    return {"dilated": dilated, "previous_depth": encoded.reshape(-1).view(np.uint32).copy()}


def outputs(c: Call) -> dict:
    h, w = c.read["depth"].shape[:2]
    return {"dilated": (h, w, 4), "previous_depth": (h * w,)}


ORDER = 500  # fsr2, first: dilation and the previous depth reconstructed

PASS = Pass(
    "fsr2_reconstruct_pass", (8, 8, 1), "lr",
    (sampler("depth", 0, "r32f"), sampler("motion", 1, "rg32f"), image("dilated", 0, "rgba32f"),
     buffer("previous_depth", 0, "uint[]", "write")),
    ("u_dilation_edge",),
    reference=reference, outputs=outputs,
)
