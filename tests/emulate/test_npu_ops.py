"""Every op of the int8 NPU graph (ops.npu_ops) is a TFLite builtin, read and run by the emulator."""

from __future__ import annotations

import pytest

from mnss_kit.emulate.interpreter import NumpyInterpreter
from mnss_kit.ops.npu_ops import NPU_OPS


def test_every_npu_op_is_a_tflite_builtin_with_its_options():
    schema = pytest.importorskip("ai_edge_litert.schema_py_generated")
    for name, op in NPU_OPS.items():
        assert hasattr(schema.BuiltinOperator, name), name
        if op.options is not None:
            assert hasattr(schema.BuiltinOptions, op.options) and hasattr(schema, op.options + "T"), name
        assert 1 <= op.version <= op.version_int16, name


def test_the_numpy_interpreter_runs_every_npu_op():
    missing = [name for name in NPU_OPS if not hasattr(NumpyInterpreter, "_prepare_" + name.lower())]
    assert missing == []
