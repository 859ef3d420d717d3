"""The runtime's formula for ADD, QUANTIZE and DEQUANTIZE, the ops whose LiteRT optimized kernel
rounds a value by where it sits in the tensor.

LiteRT's optimized builtin kernels (``tflite-builtin``) on x86 are its ARM NEON code compiled
through an SSE emulation of the NEON intrinsics.  Vector loops process 16 (ADD, int8 QUANTIZE)
or 8 (float QUANTIZE, DEQUANTIZE) values at a time with the vector rounding, and the leftover
tail runs the scalar reference formula (:func:`vector_width`, :func:`_by_position`).  Every other
formula is the scalar definition (``add.add``, ``quantize.quantize``, ``quantize.dequantize``).
Checked bit for bit against ai-edge-litert 2.3.0 and onnxruntime 1.31 on x86-64 (tests/emulate).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..runtimes import Runtime, check_formula, get_runtime
from .add import add as add_by_method
from .quantize import dequantize as dequantize_exact
from .quantize import quantize as quantize_scalar
from .ranges import QParams, _clamp_int8
from .rounding import round_float

# values per vector iteration of the formulas whose rounding depends on the position in the tensor
VECTOR_WIDTHS = {("ADD", "tflite_neon16"): 16, ("QUANTIZE", "tflite_neon8"): 8, ("DEQUANTIZE", "tflite_neon8"): 8,
                 ("REQUANTIZE", "tflite_neon16"): 16}


def vector_width(op: str, formula: str) -> int:
    """Values per vector iteration if the formula rounds the tail of a tensor differently, else 0."""
    return VECTOR_WIDTHS.get((op, formula), 0)


def _by_position(width: int, body: Callable, tail: Callable, *arrays: np.ndarray) -> np.ndarray:
    """A vector kernel over flattened ``arrays``: full blocks of ``width`` values through ``body``,
    the rest through ``tail``; both map flat arrays to flat results.  Returns the input shape."""
    flat = [np.asarray(a).reshape(-1) for a in arrays]
    split = flat[0].size // width * width
    out = np.concatenate([body(*(f[:split] for f in flat)), tail(*(f[split:] for f in flat))])
    return out.reshape(np.shape(arrays[0]))


# ---------------------------------------------------------------------------
# ADD


def add(a: np.ndarray, a_q: QParams, b: np.ndarray, b_q: QParams, out_q: QParams, formula: str,
        clamp: tuple[int, int] | None = None) -> np.ndarray:
    """Quantized ADD of two int8 tensors of one shape -> int8.

    An ADD method of ``add.add``, or ``tflite_neon16``: LiteRT's optimized kernel; the
    flattened tensor is cut into blocks of 16, full blocks take the vector formula
    (``q31_single_round_inputs``: the inputs rescaled with one rounding; NEON's truncating
    pre-shift loses no bits while the smaller input scale is at least 2^-20 of the larger) and
    the tail the reference one (``q31_double_round``).
    """
    check_formula("ADD", formula)
    if formula != "tflite_neon16":
        return add_by_method(a, a_q, b, b_q, out_q, formula, clamp=clamp)
    a, b = np.broadcast_arrays(np.asarray(a), np.asarray(b))

    def by(method):
        return lambda x, y: add_by_method(x, a_q, y, b_q, out_q, method, clamp=clamp)

    return _by_position(vector_width("ADD", formula), by("q31_single_round_inputs"), by("q31_double_round"), a, b)


# ---------------------------------------------------------------------------
# QUANTIZE float32 -> int8, DEQUANTIZE int8 -> float32


def quantize(x: np.ndarray, out_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """QUANTIZE float32 -> int8 by the runtime's ``quantize`` formula.

    ``scalar``: ``quantize.quantize`` with the runtime's rounding fields.  ``tflite_neon8``: LiteRT's
    optimized kernel; full blocks of 8 (flattened) take the vector formula (``quantize.quantize``
    with the runtime's fields: multiply by the float32 reciprocal, ties to even), the tail
    divides in float64 and rounds half away from zero.
    """
    rt = get_runtime(runtime)
    scale, zp = out_q
    if rt.quantize == "scalar":
        return quantize_scalar(x, scale, zp, "int8", rt)

    def body(v):
        return quantize_scalar(v, scale, zp, "int8", rt)

    def tail(v):
        q = round_float(v.astype(np.float64) / np.float64(np.float32(scale)), "away_from_zero") + zp
        return _clamp_int8(q, None)

    return _by_position(vector_width("QUANTIZE", rt.quantize), body, tail, np.asarray(x, dtype=np.float32))


def dequantize(x: np.ndarray, x_q: QParams, formula: str) -> np.ndarray:
    """DEQUANTIZE int8 -> float32.

    ``exact``: ``quantize.dequantize``, one rounding of ``scale * (q - zp)``.  ``tflite_neon8``:
    LiteRT's optimized kernel; full blocks of 8 compute ``float32(q) * scale - float32(zp * scale)``
    (two roundings), the tail is exact.
    """
    check_formula("DEQUANTIZE", formula)
    scale = np.float32(x_q[0])
    offset = np.float32(np.float32(x_q[1]) * scale)

    def exact(v):
        return dequantize_exact(v, x_q[0], x_q[1])

    def body(v):
        return (v.astype(np.float32) * scale).astype(np.float32) - offset

    if formula == "exact":
        return exact(x)
    return _by_position(vector_width("DEQUANTIZE", formula), body, exact, np.asarray(x))
