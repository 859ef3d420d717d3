"""taau_lr_reproject_pass (ntaau_lr): taau_reproject_pass at any scale, the LR motion resized to
the history's size (``ops.taau.hr_motion_of``)."""

from __future__ import annotations

from .record import HISTORY_FORMAT, Call, Pass, image, sampler
from .taau_reproject_pass import reprojected


def reference(c: Call) -> dict:
    return {"reprojected": reprojected(c.read["history"], c.read["motion"], 0, c.u("u_reset"), c.u("u_blur_penalty"))}


def outputs(c: Call) -> dict:
    return {"reprojected": (*c.read["history"].shape[:2], 4)}


ORDER = 400  # ntaau_lr, first: the history reprojected

PASS = Pass(
    "taau_lr_reproject_pass", (8, 8, 1), "hr",
    (sampler("history", 0, HISTORY_FORMAT), sampler("motion", 1, "rg32f"), image("reprojected", 0, "rgba16f")),
    ("u_reset", "u_blur_penalty"),
    exact=False, reference=reference, outputs=outputs,
)
