"""avgpool_pass: the AA net's input at LR: the rectified history average-pooled, with
``u_history_at_samples`` the rectified history at this frame's sampled sub-pixels, and the colour."""

from __future__ import annotations

import numpy as np

from ...ops import subpixel
from ...ops.resample import avgpool
from ...ops.sanitize import sanitize_colour
from ..storage import to_half
from .record import Call, Pass, image, sampler


def avgpool_channels(history_at_samples: bool) -> int:
    """Channels ``avgpool_pass`` writes, in order (each RGB): avgpool(I_R), then I_R at this
    frame's sampled sub-pixels when ``history_at_samples``, then the LR colour."""
    return 9 if history_at_samples else 6


def reference(c: Call) -> dict:
    """-> aa_input (h,w,6 or 9) fp16 values (``model.config.aa_input_channels``)."""
    scale = c.u("u_scale")
    rectified = to_half(c.read["rectified"])
    inputs = [avgpool(rectified, scale)]
    if c.u("u_history_at_samples"):
        inputs.append(subpixel.extract_samples(rectified, c.offset, scale))
    return {"aa_input": to_half(np.concatenate([*inputs, sanitize_colour(to_half(c.read["color"]))], axis=-1))}


def outputs(c: Call) -> dict:
    return {"aa_input": (*c.read["color"].shape[:2], avgpool_channels(bool(c.u("u_history_at_samples"))))}


ORDER = 130  # MNSS, after inpaint_blend_pass: pools the rectified history

PASS = Pass(
    "avgpool_pass", (8, 8, 1), "lr",
    (sampler("rectified", 0, "rgba16f"), sampler("color", 1, "rgba16f"), image("aa_input", 0, "rgba16f", array=True)),
    ("u_scale", "u_subpixel", "u_history_at_samples"),
    reference=reference, outputs=outputs,
)
