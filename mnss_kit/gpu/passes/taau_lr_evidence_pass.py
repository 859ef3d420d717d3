"""taau_lr_evidence_pass (ntaau_lr): the evidence at LR (``ops.taau_lr.evidence``): the depth
change, the motion spread, the trust."""

from __future__ import annotations

import numpy as np

from ...ops import taau_lr
from ...ops.sanitize import sanitize_depth, sanitize_motion
from .record import Call, Pass, image, sampler


def reference(c: Call) -> dict:
    """depth, prev_depth (h,w,1), motion (h,w,2) -> evidence (h,w,4) float32: the depth change, the
    motion spread, the trust, 0; on a reset this frame's depth stands in for the previous one
    (``prev_depth`` is not read)."""
    depth = sanitize_depth(np.asarray(c.read["depth"], np.float32))
    previous = depth if c.u("u_reset") else sanitize_depth(np.asarray(c.read["prev_depth"], np.float32))
    motion = sanitize_motion(np.asarray(c.read["motion"], np.float32))
    evidence = taau_lr.evidence(depth, previous, motion, float(np.float32(c.u("u_trust_depth"))),
                                float(np.float32(c.u("u_trust_spread_px"))))
    return {"evidence": evidence}


def outputs(c: Call) -> dict:
    return {"evidence": (*c.read["depth"].shape[:2], 4)}


ORDER = 410  # ntaau_lr, after taau_lr_reproject_pass: the evidence at LR

PASS = Pass(
    "taau_lr_evidence_pass", (8, 8, 1), "lr",
    (sampler("depth", 0, "r32f"), sampler("prev_depth", 1, "r32f"), sampler("motion", 2, "rg32f"), image("evidence", 0, "rgba32f")),
    ("u_reset", "u_trust_depth", "u_trust_spread_px"),
    exact=False, reference=reference, outputs=outputs,
)
