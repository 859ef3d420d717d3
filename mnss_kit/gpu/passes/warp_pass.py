"""warp_pass: the previous output warped to this frame along the motion (``ops.warp``), and the
previous depth, upsampled at the previous jitter and warped, read at this frame's samples."""

from __future__ import annotations

import numpy as np

from ...ops import subpixel, warp
from ...ops.sanitize import sanitize_depth, sanitize_motion
from ..storage import to_half
from .record import HISTORY_FORMAT, Call, Pass, image, sampler


def reference(c: Call) -> dict:
    """history (H,W,3), prev_depth (h,w,1), motion (h,w,2) LR pixels -> warped (H,W,3) fp16 values,
    warped_depth (h,w,1) float32 at this frame's sampled sub-pixels, ``ops.warp.OFFSCREEN_DEPTH``
    where the surface was outside the previous frame."""
    r, scale = c.read, c.u("u_scale")
    hr_motion = warp.upsample_motion(sanitize_motion(np.asarray(r["motion"], np.float32)), scale)
    hr_depth = subpixel.jittered_upsample(sanitize_depth(np.asarray(r["prev_depth"], np.float32)), c.previous_offset, scale)
    warped = warp.warp_bilinear(to_half(r["history"]), hr_motion)
    warped_depth = warp.warp_depth(hr_depth, hr_motion)
    return {"warped": to_half(warped), "warped_depth": subpixel.extract_samples(warped_depth, c.offset, scale)}


def outputs(c: Call) -> dict:
    (hh, hw), (h, w) = c.read["history"].shape[:2], c.read["motion"].shape[:2]
    return {"warped": (hh, hw, 3), "warped_depth": (h, w, 1)}


ORDER = 100  # MNSS, first: the previous output warped to this frame

PASS = Pass(
    "warp_pass", (8, 8, 1), "hr",
    (sampler("history", 0, HISTORY_FORMAT), sampler("prev_depth", 1, "r32f"), sampler("motion", 2, "rg32f"),
     image("warped", 0, "rgba16f"), image("warped_depth", 1, "r32f")),
    ("u_scale", "u_subpixel", "u_prev_jitter", "u_prev_subpixel"),
    reference=reference, outputs=outputs,
)
