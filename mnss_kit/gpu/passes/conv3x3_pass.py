"""conv3x3_pass: one learned 3x3 conv on an LR array texture (the AA net runs it once per layer),
with its epilogue: none, relu, or ``clamp(residual + conv, 0, 1)`` (``ops.sanitize.NO_SAMPLE`` where the
residual, the engine's colour, is not finite: no sample there)."""

from __future__ import annotations

import numpy as np

from ...ops.sanitize import NO_SAMPLE, colour_not_finite, sanitize_colour
from ..storage import to_half
from ..weights import layers_of
from .record import Call, Pass, buffer, image, sampler

EPILOGUE_CODES = {"none": 0, "relu": 1, "residual_clamp": 2}  # u_epilogue, as conv3x3.glsl defines it
EPILOGUES = {v: k for k, v in EPILOGUE_CODES.items()}


def _epilogue(c: Call) -> str:
    code = c.u("u_epilogue")
    if code not in EPILOGUES:
        raise ValueError(f"unknown epilogue code {code!r} (one of {EPILOGUE_CODES})")
    return EPILOGUES[code]


def reference(c: Call) -> dict:
    """x (h,w,Cin) -> y (h,w,Cout) fp16 values; ``residual`` (h,w,Cout) is read only by residual_clamp."""
    conv, epilogue = c.weights["weights"], _epilogue(c)
    acc = c.conv(to_half(c.read["x"]), conv.weight, conv.bias)
    if epilogue == "relu":
        acc = np.maximum(acc, np.float32(0))
    elif epilogue == "residual_clamp":
        residual = c.read["residual"]
        acc = np.clip(sanitize_colour(to_half(residual)) + acc, np.float32(0), np.float32(1))
        acc = np.where(colour_not_finite(residual), np.float32(NO_SAMPLE), acc)
    return {"y": to_half(acc)}


def outputs(c: Call) -> dict:
    h, w, cin = c.read["x"].shape
    conv = c.weights["weights"]
    if cin != conv.in_channels:
        raise ValueError(f"input has {cin} channels, the conv expects {conv.in_channels}")
    _epilogue(c)
    return {"y": (h, w, conv.out_channels)}


def layer_uniforms(in_channels: int, out_channels: int, epilogue: str) -> dict:
    """``u_in_layers``, ``u_out_layers`` and ``u_epilogue`` of a conv from ``in_channels`` to ``out_channels``."""
    return {"u_in_layers": layers_of(in_channels), "u_out_layers": layers_of(out_channels), "u_epilogue": EPILOGUE_CODES[epilogue]}


ORDER = 140  # MNSS AA net (once per layer), after avgpool_pass; also FuseSR's encoder, after demodulate_pass

PASS = Pass(
    "conv3x3_pass", (8, 8, 1), "lr_layers",
    (sampler("x", 0, "rgba16f", array=True), sampler("residual", 1, "rgba16f"), buffer("weights", 0, "vec4[]"),
     image("y", 0, "rgba16f", array=True)),
    ("u_in_layers", "u_out_layers", "u_epilogue"),
    reference=reference, outputs=outputs,
)
