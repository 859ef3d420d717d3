"""fsr2_rcas_pass (fsr2): robust contrast-adaptive sharpening (``ops.fsr2.rcas``)."""

from __future__ import annotations

import numpy as np

from ...ops import fsr2
from ..storage import to_half
from .record import HISTORY_FORMAT, Call, Pass, image, sampler


def reference(c: Call) -> dict:
    """image (H,W,3) -> output_image (H,W,3) fp16 values."""
    return {"output_image": to_half(fsr2.rcas(to_half(c.read["image"])[..., :3], float(np.float32(c.u("u_sharpness")))))}


def outputs(c: Call) -> dict:
    return {"output_image": (*c.read["image"].shape[:2], 3)}


ORDER = 530  # fsr2, last: sharpened into the display

PASS = Pass(
    "fsr2_rcas_pass", (8, 8, 1), "hr",
    (sampler("image", 0, HISTORY_FORMAT), image("output_image", 0, "rgba16f")),
    ("u_sharpness",),
    exact=False, reference=reference, outputs=outputs,
)
