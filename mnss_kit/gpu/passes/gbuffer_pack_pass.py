"""gbuffer_pack_pass (FuseSR): the NPU input at LR: L, the encoder's features, the warped history
and the HR G-buffers, HR images pixel-unshuffled (``ops.demodulation.pixel_unshuffle``), int8."""

from __future__ import annotations

import numpy as np

from ...ops import demodulation
from ...ops.int8 import quantize as quant
from ...ops.sanitize import sanitize_depth
from ..storage import to_half
from .record import Call, Pass, buffer, sampler

# HR G-buffers the pass reads, in its channel order; bit i of u_gbuffers selects entry i
PACKED_GBUFFERS = ("fbeta", "normal", "depth", "albedo")


def _gbuffers(c: Call) -> dict:
    """The G-buffers ``u_gbuffers`` selects: name -> (H,W,C)."""
    mask = c.u("u_gbuffers")
    return {name: c.read[name] for i, name in enumerate(PACKED_GBUFFERS) if mask & (1 << i)}


def reference(c: Call) -> dict:
    """-> npu_input (1,h,w,C) int8: [L, the first ``u_features`` features, with ``u_history`` the warped
    history (zero on a reset, when ``warped`` is not read), the selected G-buffers], quantized as
    ``ops.int8.quantize.quantize`` under the profile.  Depth is r32f (float32), the rest fp16."""
    scale = c.u("u_scale")
    parts = [to_half(c.read["l"])[..., :3], to_half(c.read["features"][..., : c.u("u_features")])]
    if c.u("u_history"):
        h, w = parts[0].shape[:2]
        hr = np.zeros((h * scale, w * scale, 3), np.float32) if c.u("u_reset") else to_half(np.asarray(c.read["warped"])[..., :3])
        parts.append(demodulation.pixel_unshuffle(hr, scale))
    for name, image in _gbuffers(c).items():
        stored = sanitize_depth(np.asarray(image, np.float32)) if name == "depth" else to_half(image)
        parts.append(demodulation.pixel_unshuffle(stored, scale))
    packed = quant.quantize(np.concatenate(parts, axis=-1), c.u("u_q_scale"), c.u("u_q_zero_point"), "int8", c.profile)
    return {"npu_input": packed[None]}


def outputs(c: Call) -> dict:
    h, w = c.read["l"].shape[:2]
    s = c.u("u_scale")
    channels = 3 + c.u("u_features") + (3 * s * s if c.u("u_history") else 0)
    channels += sum(g.shape[-1] for g in _gbuffers(c).values()) * s * s
    return {"npu_input": (1, h, w, channels)}


ORDER = 210  # FuseSR, after the encoder: packs the NPU input (the NPU runs next)

PASS = Pass(
    "gbuffer_pack_pass", (64, 1, 1), "words",
    (sampler("l", 0, "rgba16f", array=True), sampler("features", 1, "rgba16f", array=True), sampler("warped", 2, "rgba16f"),
     sampler("fbeta", 3, "rgba16f"), sampler("normal", 4, "rgba16f"), sampler("depth", 5, "r32f"), sampler("albedo", 6, "rgba16f"),
     buffer("npu_input", 0, "uint[]", "write", "int8")),
    ("u_scale", "u_features", "u_history", "u_reset", "u_gbuffers", "u_word_count", "u_q_scale", "u_q_reciprocal",
     "u_q_use_reciprocal", "u_q_rounding", "u_q_zero_point"),
    reference=reference, outputs=outputs,
)
