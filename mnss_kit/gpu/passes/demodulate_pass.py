"""demodulate_pass (FuseSR): the LR colour demodulated by the pre-integrated BRDF
(``ops.demodulation.demodulate``), or the colour itself without demodulation."""

from __future__ import annotations

from ...ops import demodulation
from ...ops.sanitize import sanitize_colour
from ..storage import to_half
from .record import Call, Pass, image, sampler


def reference(c: Call) -> dict:
    """color, fbeta, emissive (h,w,3) -> l (h,w,3) fp16 values (the colour, sanitized, with
    ``u_demodulate`` 0: ``fbeta`` and ``emissive`` are not read)."""
    color = sanitize_colour(to_half(c.read["color"]))
    if not c.u("u_demodulate"):
        return {"l": color}
    return {"l": to_half(demodulation.demodulate(color, to_half(c.read["fbeta"]), to_half(c.read["emissive"])))}


def outputs(c: Call) -> dict:
    return {"l": (*c.read["color"].shape[:2], 3)}


ORDER = 200  # FuseSR, after warp_pass; its encoder (conv3x3_pass, listed at 140) runs next

PASS = Pass(
    "demodulate_pass", (8, 8, 1), "lr",
    (sampler("color", 0, "rgba16f"), sampler("fbeta", 1, "rgba16f"), sampler("emissive", 2, "rgba16f"),
     image("l", 0, "rgba16f", array=True)),
    ("u_demodulate",),
    exact=False, reference=reference, outputs=outputs,
)
