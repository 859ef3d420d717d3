"""Kernel sets are data naming formulas defined once in ops.quant / ops.quant_ops."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mnss_kit.emulate.npu import NPU_PROFILES
from mnss_kit.emulate.profiles import KERNEL_SETS, get_kernel_set
from mnss_kit.ops import quant, quant_ops


def test_every_npu_profile_has_a_kernel_set():
    assert {p.kernel_set for p in NPU_PROFILES.values()} == set(KERNEL_SETS)
    assert {ks.resolver for ks in KERNEL_SETS.values()} == {p.litert_resolver for p in NPU_PROFILES.values()}


@pytest.mark.parametrize("field, value", [("add", "float32"), ("mul", "tflite_reference"), ("numerics", "hexagon"),
                                          ("requantize", "xnnpack")])
def test_unknown_formula_is_refused(field, value):
    with pytest.raises(ValueError, match=value):
        dataclasses.replace(KERNEL_SETS["tflite_reference"], **{field: value})
    with pytest.raises(ValueError, match="unknown kernel set"):
        get_kernel_set("hexagon")


def test_profile_named_formulas_are_the_ops_quant_definitions():
    """ADD and QUANTIZE under a profile's name are ops.quant's add and quantize under that profile."""
    rng = np.random.default_rng(0)
    a, b = (rng.integers(-128, 128, size=(1, 5, 7, 3)).astype(np.int8) for _ in range(2))
    qs = [(np.float32(0.02), 5), (np.float32(0.031), -7), (np.float32(0.05), -3)]
    x = (rng.standard_normal((1, 5, 7, 3)) * 2).astype(np.float32)
    for profile in quant.PROFILES:
        expected = quant.add(a, qs[0], b, qs[1], qs[2], profile)
        np.testing.assert_array_equal(quant_ops.add(a, qs[0], b, qs[1], qs[2], profile), expected)
        np.testing.assert_array_equal(quant_ops.quantize(x, qs[0], profile), quant.quantize(x, *qs[0], "int8", profile))


@pytest.mark.parametrize("op", ["ADD", "REQUANTIZE"])
def test_vector_formulas_split_by_position(op):
    """LiteRT's optimized kernels: full vectors take the single-rounding formula, the tail the reference one.

    Built from every int8 operand pair: the vector body holds all of them, the tail pairs on
    which the two formulas differ, so each region shows which formula ran.
    """
    q_a, q_b, q_out = (np.float32(0.05), 5), (np.float32(0.0375), -7), (np.float32(0.05), -3)  # tie-prone ratios 1, 0.75
    a = np.repeat(np.arange(-128, 128), 256).astype(np.int8)
    b = np.tile(np.arange(-128, 128), 256).astype(np.int8)

    def run(name, a, b):
        if op == "ADD":
            return quant_ops.add(a, q_a, b, q_b, q_out, name)
        return quant_ops.requantize_int8(a, q_a, (np.float32(4 * 0.05), 3), name)  # ratio 1/4: ties

    vector, scalar = run("tflite_optimized", a, b), run("tflite_reference", a, b)
    differ = np.flatnonzero(vector != scalar)
    assert differ.size > 0, "the test values must tell the two formulas apart"
    tail = differ[: quant_ops.vector_width(op, "tflite_neon16") - 1]
    a2, b2 = np.concatenate([a, a[tail]]), np.concatenate([b, b[tail]])
    got = run("tflite_neon16", a2, b2)
    np.testing.assert_array_equal(got[: a.size], vector)
    np.testing.assert_array_equal(got[a.size:], scalar[tail])


def test_only_vector_formulas_depend_on_position():
    assert quant_ops.vector_width("ADD", "tflite_neon16") == 16
    assert quant_ops.vector_width("ADD", "tflite_reference") == 0
    assert all(f in quant_ops.FORMULAS[op] for op, f in quant_ops.VECTOR_WIDTHS)
