"""fsr2_depth_clip_pass (fsr2): the disocclusion from the reconstructed previous depth
(``ops.fsr2.disocclusion``) and the thin features of the colour (``ops.fsr2.thin_features``)."""

from __future__ import annotations

import numpy as np

from ...ops import fsr2
from ...ops.sanitize import sanitize_colour
from ..storage import to_half
from .fsr2_params import fsr2_params_from_uniforms
from .record import Call, Pass, buffer, image, sampler


def reference(c: Call) -> dict:
    """dilated (h,w,4), color (h,w,3), previous_depth (h*w,) uint32 -> analysis (h,w,4): the
    disocclusion, the thin features, 0, 0."""
    params = fsr2_params_from_uniforms(c.uniforms)
    dilated = c.read["dilated"]
    h, w = dilated.shape[:2]
    previous = fsr2.decode_depth(np.asarray(c.read["previous_depth"], np.uint32).view(np.float32).reshape(h, w))[..., None]
    clip = fsr2.disocclusion(dilated[..., 0:1], dilated[..., 1:3], previous, params)
    thin = fsr2.thin_features(sanitize_colour(to_half(c.read["color"]))[..., :3], params.lock_contrast)
    return {"analysis": np.concatenate([clip, thin, np.zeros((h, w, 2), np.float32)], axis=-1)}


def outputs(c: Call) -> dict:
    return {"analysis": (*c.read["dilated"].shape[:2], 4)}


ORDER = 510  # fsr2, after fsr2_reconstruct_pass: disocclusion, thin features

PASS = Pass(
    "fsr2_depth_clip_pass", (8, 8, 1), "lr",
    (sampler("dilated", 0, "rgba32f"), sampler("color", 1, "rgba16f"), buffer("previous_depth", 0, "uint[]"),
     image("analysis", 0, "rgba32f")),
    ("u_depth_tolerance", "u_slope_factor", "u_lock_contrast"),
    exact=False, reference=reference, outputs=outputs,
)
