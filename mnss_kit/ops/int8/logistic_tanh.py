"""LOGISTIC and TANH: every runtime builds a 256-entry int8 table in float32 and looks values up.

The output parameters are fixed: (1/256, -128) for LOGISTIC, (1/128, 0) for TANH.
"""

from __future__ import annotations

import numpy as np

from ..runtimes import Runtime, get_runtime
from .ranges import INT8_MAX, INT8_MIN, QParams
from .rounding import round_float

LOGISTIC_OUTPUT = (np.float32(1.0 / 256.0), -128)  # fixed output params of int8 LOGISTIC
TANH_OUTPUT = (np.float32(1.0 / 128.0), 0)  # fixed output params of int8 TANH


def lookup_table(fn, in_params: tuple[float, int], out_params: tuple[float, int], runtime: str | Runtime) -> np.ndarray:
    """256-entry int8 table of ``fn`` (a float32 numpy ufunc-like) indexed by ``q + 128``.

    Built in float32 as the runtimes do: ``x = s_in * (q - z_in)``,
    ``y = round(fn(x) * (1 / s_out)) + z_out`` (the runtime's ``table_rounding``), clamped to
    int8.  Returns int8 (256,).
    """
    p = get_runtime(runtime)
    (s_in, z_in), (s_out, z_out) = in_params, out_params
    q = np.arange(INT8_MIN, INT8_MAX + 1, dtype=np.int64)
    x = (np.float32(s_in) * (q - z_in).astype(np.float32)).astype(np.float32)
    y = np.asarray(fn(x), dtype=np.float32)
    scaled = (y * (np.float32(1.0) / np.float32(s_out))).astype(np.float32)
    return np.clip(round_float(scaled, p.table_rounding) + z_out, INT8_MIN, INT8_MAX).astype(np.int8)


def sigmoid_f32(x: np.ndarray) -> np.ndarray:
    """``1 / (1 + exp(-x))`` in float32 (exp overflow gives 1/inf = 0, the right limit)."""
    x = np.asarray(x, dtype=np.float32)
    with np.errstate(over="ignore"):
        return (np.float32(1.0) / (np.float32(1.0) + np.exp(-x))).astype(np.float32)


def tanh_f32(x: np.ndarray) -> np.ndarray:
    return np.tanh(np.asarray(x, dtype=np.float32)).astype(np.float32)


def apply_table(q: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Look up int8 ``q`` in a 256-entry int8 table built by :func:`lookup_table`."""
    return table[np.asarray(q, dtype=np.int64) - INT8_MIN]


def logistic(x: np.ndarray, x_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """int8 LOGISTIC through ``lookup_table`` of ``sigmoid_f32``; output params (1/256, -128)."""
    with np.errstate(over="ignore"):  # exp overflow gives 1/inf = 0, the right limit
        table = lookup_table(sigmoid_f32, x_q, LOGISTIC_OUTPUT, runtime)
    return apply_table(x, table)


def tanh(x: np.ndarray, x_q: QParams, runtime: str | Runtime) -> np.ndarray:
    """int8 TANH through ``lookup_table`` of ``tanh_f32``; output params (1/128, 0).

    ONNX Runtime keeps a QDQ Tanh as float (dequantize, ``tanh``, quantize), which gives the
    table's values wherever its ``tanh`` and numpy's agree to the last bit.
    """
    return apply_table(x, lookup_table(tanh_f32, x_q, TANH_OUTPUT, runtime))
