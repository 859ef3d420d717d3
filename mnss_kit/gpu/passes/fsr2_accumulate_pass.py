"""fsr2_accumulate_pass (fsr2): the history and the locks accumulated (``ops.fsr2.accumulate``);
the reconstructed previous depth is cleared for the next frame."""

from __future__ import annotations

import numpy as np

from ...ops import fsr2
from ...ops.sanitize import sanitize_colour
from ..storage import to_half
from .fsr2_params import fsr2_params_from_uniforms
from .record import HISTORY_FORMAT, Call, Pass, buffer, image, sampler


def reference(c: Call) -> dict:
    """-> next_history (H,W,4) and next_locks (H,W,2) fp16 values, previous_depth cleared to zeros.
    ``reactive`` (h,w,1) is read with ``u_use_reactive``."""
    r = c.read
    reactive = np.asarray(r["reactive"], np.float32) if c.u("u_use_reactive") else None
    next_history, next_locks = fsr2.accumulate(
        sanitize_colour(to_half(r["color"]))[..., :3], r["dilated"][..., 1:3], r["analysis"][..., 0:2],
        to_half(r["history"]), to_half(r["locks"])[..., :2], c.offset, c.u("u_scale"), bool(c.u("u_reset")),
        fsr2_params_from_uniforms(c.uniforms), reactive)
    return {"next_history": to_half(next_history), "next_locks": to_half(next_locks),
            "previous_depth": np.zeros_like(np.asarray(r["previous_depth"], np.uint32))}


def outputs(c: Call) -> dict:
    hh, hw = c.read["history"].shape[:2]
    return {"next_history": (hh, hw, 4), "next_locks": (hh, hw, 2), "previous_depth": np.asarray(c.read["previous_depth"]).shape}


ORDER = 520  # fsr2, after fsr2_depth_clip_pass: the history accumulated

PASS = Pass(
    "fsr2_accumulate_pass", (8, 8, 1), "hr",
    (sampler("color", 0, "rgba16f"), sampler("dilated", 1, "rgba32f"), sampler("analysis", 2, "rgba32f"),
     sampler("history", 3, HISTORY_FORMAT), sampler("locks", 4, "rgba16f"), sampler("reactive", 5, "r32f"),
     image("next_history", 0, HISTORY_FORMAT), image("next_locks", 1, "rgba16f"), buffer("previous_depth", 0, "uint[]", "read_write")),
    ("u_scale", "u_jitter", "u_reset", "u_use_reactive", "u_max_weight", "u_gamma", "u_resample_penalty",
     "u_kernel_width", "u_prior_weight", "u_lock_decay", "u_lock_luma_tolerance"),
    exact=False, reference=reference, outputs=outputs,
)
