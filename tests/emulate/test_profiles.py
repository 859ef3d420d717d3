"""Runtimes are data naming formulas defined once in ops.int8."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mnss_kit.ops.int8 import vector as int8_vector
from mnss_kit.ops.int8.add import add
from mnss_kit.ops.int8.quantize import quantize
from mnss_kit.ops.int8.requantize import requantize, requantize_int8
from mnss_kit.ops.runtimes import ADD_METHODS, FORMULAS, RUNTIMES, get_runtime


def test_every_litert_runtime_names_a_resolver_of_litert():
    litert = pytest.importorskip("ai_edge_litert.interpreter")
    for runtime in RUNTIMES.values():
        assert runtime.depthwise_tail in RUNTIMES
        if runtime.engine == "litert":
            assert hasattr(litert.OpResolverType, runtime.litert_resolver), runtime.name
    assert len({r.litert_resolver for r in RUNTIMES.values()}) == len(RUNTIMES)


@pytest.mark.parametrize("field, value", [("add", "float32"), ("mul", "tflite-ref"), ("multiplier", "hexagon"),
                                          ("requantize", "xnnpack"), ("quantize_rounding", "half_down")])
def test_unknown_formula_is_refused(field, value):
    with pytest.raises(ValueError, match=value):
        dataclasses.replace(RUNTIMES["tflite-ref"], **{field: value})
    with pytest.raises(ValueError, match="unknown runtime"):
        get_runtime("hexagon")


def test_scalar_formulas_are_the_ops_quant_definitions():
    """ADD methods and the scalar QUANTIZE formula are ops.int8's add.add and quantize.quantize under the runtime."""
    rng = np.random.default_rng(0)
    a, b = (rng.integers(-128, 128, size=(1, 5, 7, 3)).astype(np.int8) for _ in range(2))
    qs = [(np.float32(0.02), 5), (np.float32(0.031), -7), (np.float32(0.05), -3)]
    x = (rng.standard_normal((1, 5, 7, 3)) * 2).astype(np.float32)
    for method in ADD_METHODS:
        expected = add(a, qs[0], b, qs[1], qs[2], method)
        np.testing.assert_array_equal(int8_vector.add(a, qs[0], b, qs[1], qs[2], method), expected)
    for runtime in RUNTIMES.values():
        if runtime.quantize == "scalar":
            np.testing.assert_array_equal(int8_vector.quantize(x, qs[0], runtime), quantize(x, *qs[0], "int8", runtime))


@pytest.mark.parametrize("op", ["ADD", "REQUANTIZE"])
def test_vector_formulas_split_by_position(op):
    """LiteRT's optimized kernels: full vectors take the single-rounding formula, the tail the reference one.

    Built from every int8 operand pair: the vector body holds all of them, the tail pairs on
    which the two formulas differ, so each region shows which formula ran.
    """
    q_a, q_b, q_out = (np.float32(0.05), 5), (np.float32(0.0375), -7), (np.float32(0.05), -3)  # tie-prone ratios 1, 0.75
    q_requantized = (np.float32(4 * 0.05), 3)  # ratio 1/4: ties
    a = np.repeat(np.arange(-128, 128), 256).astype(np.int8)
    b = np.tile(np.arange(-128, 128), 256).astype(np.int8)

    def scalar(part, a, b):  # part: "vector" or "tail"
        if op == "ADD":
            method = "q31_single_round_inputs" if part == "vector" else "q31_double_round"
            return add(a, q_a, b, q_b, q_out, method)
        rule = "tflite-builtin" if part == "vector" else "tflite-ref"
        return requantize(a.astype(np.int64) - q_a[1], q_a[0], np.float32(1.0), *q_requantized, rule)

    def builtin(a, b):
        if op == "ADD":
            return int8_vector.add(a, q_a, b, q_b, q_out, RUNTIMES["tflite-builtin"].add)
        return requantize_int8(a, q_a, q_requantized, "tflite-builtin")

    vector, tail_rule = scalar("vector", a, b), scalar("tail", a, b)
    differ = np.flatnonzero(vector != tail_rule)
    assert differ.size > 0, "the test values must tell the two formulas apart"
    tail = differ[: int8_vector.vector_width(op, RUNTIMES["tflite-builtin"].formula(op)) - 1]
    got = builtin(np.concatenate([a, a[tail]]), np.concatenate([b, b[tail]]))
    np.testing.assert_array_equal(got[: a.size], vector)
    np.testing.assert_array_equal(got[a.size:], tail_rule[tail])


def test_only_vector_formulas_depend_on_position():
    assert int8_vector.vector_width("ADD", "tflite_neon16") == 16
    assert int8_vector.vector_width("ADD", "q31_double_round") == 0
    assert all(f in FORMULAS[op] for op, f in int8_vector.VECTOR_WIDTHS)
