"""What a GPU pass file declares: its bindings and uniforms (:class:`Pass`), and what one run of
it sees (:class:`Call`), the one argument of its numpy reference and of every backend.

Formats are GL sized internal formats.  Image stores in GLSL ES 3.10 accept only rgba32f,
rgba16f, r32f, rgba8(_snorm) and the integer ones, so one-channel float intermediates are r32f.
Inputs the engine renders (colour, depth, motion) are read with ``texelFetch`` and could have
any float format; the formats below are the ones the harness and the emulator assume.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ...ops import inpaint
from ...ops.jitter import subpixel_index
from ...ops.runtimes import DEFAULT_RUNTIME, get_runtime
from ..storage import as_jitter
from ..weights import Conv3x3

# Storage formats of the frame inputs and of the state kept between frames.
INPUT_FORMATS = {"color": "rgba16f", "depth": "r32f", "motion": "rg32f"}
HISTORY_FORMAT = "rgba16f"
DISPLAY_FORMAT = "rgba8"
NPU_TENSOR = {"layout": "NHWC", "shape": "(1, H, W, 3)", "dtype": "int8", "packing": "4 bytes per uint32, little-endian"}

# Values of u_q_rounding, as quant.glsl defines them.
ROUNDING_CODES = {"away_from_zero": 0, "half_even": 1, "half_up": 2}


@dataclass(frozen=True)
class Binding:
    """One shader resource.  ``kind``: ``sampler`` (texelFetch input), ``image`` (imageStore output)
    or ``buffer`` (std430 SSBO); ``unit`` is its binding point in that kind's namespace.  A buffer's
    ``access`` says whether the pass reads it (``read``), writes it whole (``write``, zero before the
    pass) or both (``read_write``); ``dtype`` is the numpy type of its elements as the reference
    holds them (the shader sees 32-bit words)."""

    name: str
    kind: str
    unit: int
    format: str  # sized texture format, or the SSBO element type ("vec4[]", "uint[]")
    array: bool = False  # a 2D array texture (channels in layers of four)
    access: str = "read"
    dtype: str = "uint32"

    @property
    def writes(self) -> bool:
        return self.kind == "image" or self.kind == "buffer" and self.access != "read"


def sampler(name: str, unit: int, fmt: str, array: bool = False) -> Binding:
    return Binding(name, "sampler", unit, fmt, array)


def image(name: str, unit: int, fmt: str, array: bool = False) -> Binding:
    return Binding(name, "image", unit, fmt, array)


def buffer(name: str, unit: int, element: str, access: str = "read", dtype: str = "uint32") -> Binding:
    if access not in ("read", "write", "read_write"):
        raise ValueError(f"buffer {name}: access {access!r} is not read, write or read_write")
    return Binding(name, "buffer", unit, element, access=access, dtype=dtype)


@dataclass
class Call:
    """What one run of a pass sees: bound resources (``read``: binding name -> array; an output
    binding reads its old value, None where there is none), uniform values as the shader holds them
    (a reset arrives as ``u_reset``), learned weights (binding name -> :class:`Conv3x3`), this and
    the previous frame's jitter (LR pixels), the numerics profile of the NPU-input quantization, and
    the 3x3 convolution the reference uses (``ops.inpaint.conv3x3`` or one of identical values)."""

    read: dict[str, np.ndarray | None]
    uniforms: dict
    weights: dict[str, Conv3x3] = field(default_factory=dict)
    offset: np.ndarray = field(default_factory=lambda: np.zeros(2, np.float32))
    previous_offset: np.ndarray = field(default_factory=lambda: np.zeros(2, np.float32))
    profile: str = DEFAULT_RUNTIME
    conv: Callable = inpaint.conv3x3

    def u(self, name: str):
        return self.uniforms[name]


@dataclass(frozen=True)
class Pass:
    """One GPU pass: its shader's interface (what the bundle manifest lists and the Mesa harness
    binds by), its numpy reference ``reference(call) -> {written binding: array}``, and
    ``outputs(call) -> {written binding: shape}`` (``(H, W, C)`` for an image, C the channels the
    reference returns; the array's shape for a buffer), the sizes a backend allocates."""

    name: str
    local_size: tuple[int, int, int]
    grid: str  # what one invocation covers: "hr" texel, "lr" texel, "lr_layers" (LR texel x
    #            output layer) or "words" (32-bit word of the NPU tensor)
    bindings: tuple[Binding, ...]
    uniforms: tuple[str, ...]
    # bit for bit the numpy reference on an IEEE float32 GPU; False: a float path through the
    # driver's pow() (BRDF demodulation), within one code of it
    exact: bool = True
    reference: Callable[[Call], dict] | None = field(default=None, compare=False, repr=False)
    outputs: Callable[[Call], dict] | None = field(default=None, compare=False, repr=False)

    @property
    def entry(self) -> str:
        return f"{self.name}.comp"

    def binding(self, name: str) -> Binding:
        return next(b for b in self.bindings if b.name == name)


def quantize_uniforms(scale: float, zero_point: int, profile) -> dict:
    """The ``u_q_*`` uniforms of quant.glsl's int8 quantize for ``ops.int8.quantize.quantize`` under
    ``profile`` (a runtime name or an ``ops.runtimes.Runtime``): the float32 scale, its float32
    reciprocal (computed here, as the runtime computes it), which of the two the runtime uses,
    the tie rule and the zero point."""
    p = get_runtime(profile)
    s = np.float32(scale)
    return {
        "u_q_scale": float(s),
        "u_q_reciprocal": float(np.float32(1.0) / s),
        "u_q_use_reciprocal": int(p.quantize_reciprocal),
        "u_q_rounding": ROUNDING_CODES[p.quantize_rounding],
        "u_q_zero_point": int(zero_point),
    }


def dequantize_uniforms(scale: float, zero_point: int) -> dict:
    """The ``u_q_*`` uniforms of quant.glsl's int8 dequantize: the float32 scale and the zero point."""
    return {"u_q_scale": float(np.float32(scale)), "u_q_zero_point": int(zero_point)}


def frame_uniforms(jitter, previous_jitter, scale: int) -> dict:
    """The per-frame uniforms of the jitter (``plan.FRAME_KEYS``): ``u_jitter`` and ``u_prev_jitter``
    (vec2, LR pixels) and, at an integer ``scale``, ``u_subpixel`` and ``u_prev_subpixel`` (the
    sampled sub-pixel, ``ops.jitter.subpixel_index``)."""
    jitter = as_jitter(jitter)
    previous = jitter if previous_jitter is None else as_jitter(previous_jitter)
    values = {"u_jitter": tuple(float(v) for v in jitter), "u_prev_jitter": tuple(float(v) for v in previous)}
    if scale:
        values["u_subpixel"] = tuple(int(v) for v in subpixel_index(jitter, scale))
        values["u_prev_subpixel"] = tuple(int(v) for v in subpixel_index(previous, scale))
    return values


def call(read: dict, uniforms: dict, jitter=(0.0, 0.0), previous_jitter=None, scale: int = 0,
         profile: str = DEFAULT_RUNTIME) -> Call:
    """A :class:`Call` for a pass run outside a schedule (the mnss GPU stage, tests).

    ``read``: binding name -> array, or a :class:`Conv3x3` for a weight buffer; ``uniforms``: the
    shader's values.  The per-frame jitter uniforms (:func:`frame_uniforms`) are added where
    ``uniforms`` does not give them (a pass ignores those it does not declare)."""
    weights = {k: v for k, v in read.items() if isinstance(v, Conv3x3)}
    arrays = {k: v for k, v in read.items() if k not in weights}
    values = {**frame_uniforms(jitter, previous_jitter, scale), **uniforms}
    previous = jitter if previous_jitter is None else previous_jitter
    return Call(arrays, values, weights, as_jitter(jitter), as_jitter(previous), profile)
