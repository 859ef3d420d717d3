"""sharpen_pass: the output through the unsharp mask (``ops.sharpen.unsharp``) into the display."""

from __future__ import annotations

from ...ops import sharpen
from ..storage import encode_unorm8, to_half
from .record import DISPLAY_FORMAT, HISTORY_FORMAT, Call, Pass, image, sampler


def reference(c: Call) -> dict:
    """image (H,W,3) -> display (H,W,3) uint8."""
    return {"display": encode_unorm8(sharpen.unsharp(to_half(c.read["image"]), c.u("u_beta")))}


def outputs(c: Call) -> dict:
    return {"display": (*c.read["image"].shape[:2], 3)}


ORDER = 170  # MNSS, last: the output into the display

PASS = Pass(
    "sharpen_pass", (8, 8, 1), "hr",
    (sampler("image", 0, HISTORY_FORMAT), image("display", 0, DISPLAY_FORMAT)),
    ("u_beta",),
    reference=reference, outputs=outputs,
)
