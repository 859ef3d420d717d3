"""taau_reproject_pass (ntaau): the TAAU history reprojected along the motion, in YCoCg, with its
weight (``ops.taau.reprojected_history``)."""

from __future__ import annotations

import numpy as np

from ...ops import taau
from ...ops.sanitize import sanitize_motion
from ..storage import to_half
from .record import HISTORY_FORMAT, Call, Pass, image, sampler


def reprojected(history, motion, scale: int, reset, blur_penalty: float) -> np.ndarray:
    """history (H,W,4): the previous output (rgb) and its weight (a); motion (h,w,2) LR pixels ->
    (H,W,4) fp16 values: the reprojected YCoCg history and its weight (``scale`` 0: any scale, the
    motion resized by the sizes' ratio, ``ops.taau.hr_motion_of``)."""
    stored = to_half(history)
    colour, weight = taau.reprojected_history(stored[..., :3], stored[..., 3:], sanitize_motion(motion), bool(reset), scale,
                                               True, blur_penalty)
    return to_half(np.concatenate([colour, weight], axis=-1))


def reference(c: Call) -> dict:
    return {"reprojected": reprojected(c.read["history"], c.read["motion"], c.u("u_scale"), c.u("u_reset"), c.u("u_blur_penalty"))}


def outputs(c: Call) -> dict:
    return {"reprojected": (*c.read["history"].shape[:2], 4)}


ORDER = 300  # ntaau, first: the history reprojected

PASS = Pass(
    "taau_reproject_pass", (8, 8, 1), "hr",
    (sampler("history", 0, HISTORY_FORMAT), sampler("motion", 1, "rg32f"), image("reprojected", 0, "rgba16f")),
    ("u_scale", "u_reset", "u_blur_penalty"),
    exact=False, reference=reference, outputs=outputs,
)
