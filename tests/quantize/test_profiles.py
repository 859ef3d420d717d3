"""Each runtime of mnss_kit.ops.runtimes is reproduced bit for bit by its formulas.

One-op graphs are written with the toolkit's own writers and run in LiteRT
(tflite-ref, tflite-builtin, xnnpack) and ONNX Runtime (ort-cpu); the numpy
reference with the runtime's formulas must give identical integers, and (so the
test can fail) at least one other runtime's formula must not.
"""

import numpy as np
import pytest

from mnss_kit.ops.int8 import vector
from mnss_kit.ops.int8.conv import conv2d_accumulate
from mnss_kit.ops.int8.logistic_tanh import LOGISTIC_OUTPUT, TANH_OUTPUT, apply_table, lookup_table, sigmoid_f32, tanh_f32
from mnss_kit.ops.int8.requantize import requantize
from mnss_kit.ops.int8.weights import bias_scales, quantize_bias, quantize_weights_per_channel
from mnss_kit.ops.runtimes import RUNTIMES, runtime_names
from mnss_kit.quantize.graph import Graph, Op, Tensor
from mnss_kit.quantize.onnx_writer import to_onnx
from mnss_kit.quantize.runtime import OnnxRunner, TfliteRunner, open_runner
from mnss_kit.quantize.tflite_writer import to_tflite


def act(name, shape, scale, zp, dtype="int8"):
    return Tensor(name=name, shape=shape, dtype=dtype, scale=np.float32(scale), zero_point=zp, channel_order=np.arange(shape[3]))


def run(graph: Graph, inputs, runtime: str) -> np.ndarray:
    return open_runner(runtime, to_tflite(graph), to_onnx(graph)).run(inputs)[graph.outputs[0]]


def conv_graph(depthwise: bool, seed: int = 0):
    rng = np.random.default_rng(seed)
    cin, size = 16, 24
    cout = cin if depthwise else 24
    x = act("x", (1, size, size, cin), 0.021, 5)
    y = act("y", (1, size, size, cout), 0.047, -3)
    w_shape, axis = ((1, 3, 3, cout), 3) if depthwise else ((cout, 3, 3, cin), 0)
    w_float = (rng.normal(size=w_shape) * 0.1).astype(np.float32)
    wq, ws = quantize_weights_per_channel(w_float, axis)
    b_float = (rng.normal(size=cout) * 0.3).astype(np.float32)
    w = Tensor("w", w_shape, "int8", ws, np.zeros(cout, np.int64), axis, wq, w_float)
    b = Tensor("b", (cout,), "int32", bias_scales(x.scale, ws), np.zeros(cout, np.int64), 0, quantize_bias(b_float, x.scale, ws), b_float)
    kind = "DEPTHWISE_CONV_2D" if depthwise else "CONV_2D"
    opts = dict(stride=(1, 1), dilation=(1, 1), padding="SAME", activation="none")
    g = Graph({t.name: t for t in (x, y, w, b)}, [Op(kind, ["x", "w", "b"], ["y"], opts)], ["x"], ["y"])
    g.validate()
    xq = rng.integers(-128, 128, size=x.shape).astype(np.int8)
    acc = conv2d_accumulate(xq, x.zero_point, wq, b.data, padding=(1, 1, 1, 1), depthwise=depthwise)

    def expected(profile):
        return requantize(acc, x.scale, ws, y.scale, y.zero_point, profile)

    return g, [xq], expected


def add_graph(seed: int = 0):
    a, b = act("a", (1, 256, 256, 1), 0.02, 5), act("b", (1, 256, 256, 1), 0.031, -7)
    y = act("y", (1, 256, 256, 1), 0.05, -3)
    g = Graph({t.name: t for t in (a, b, y)}, [Op("ADD", ["a", "b"], ["y"], {"activation": "none"})], ["a", "b"], ["y"])
    aq = np.repeat(np.arange(-128, 128), 256).reshape(a.shape).astype(np.int8)  # every pair of inputs
    bq = np.tile(np.arange(-128, 128), 256).reshape(b.shape).astype(np.int8)

    def expected(formula):
        return vector.add(aq, a.params(), bq, b.params(), y.params(), formula)

    return g, [aq, bq], expected


def table_graph(kind: str):
    x = act("x", (1, 16, 16, 1), 0.0312, -100)
    scale, zp = LOGISTIC_OUTPUT if kind == "LOGISTIC" else TANH_OUTPUT
    y = act("y", (1, 16, 16, 1), scale, zp)
    g = Graph({"x": x, "y": y}, [Op(kind, ["x"], ["y"])], ["x"], ["y"])
    xq = np.arange(-128, 128).reshape(x.shape).astype(np.int8)
    fn = sigmoid_f32 if kind == "LOGISTIC" else tanh_f32

    def expected(profile):
        return apply_table(xq, lookup_table(fn, x.params(), y.params(), profile))

    return g, [xq], expected


@pytest.mark.parametrize("runtime", list(RUNTIMES))
@pytest.mark.parametrize("depthwise", [False, True])
def test_conv_requantization_bit_exact(runtime, depthwise):
    g, inputs, expected = conv_graph(depthwise)
    got = run(g, inputs, runtime)
    np.testing.assert_array_equal(got, expected(runtime))
    others = [p for p in RUNTIMES if p != runtime]
    assert any(np.any(expected(p) != got) for p in others), "the test data must tell the runtimes apart"


@pytest.mark.parametrize("runtime", list(RUNTIMES))
def test_add_bit_exact(runtime):
    g, inputs, expected = add_graph()
    got = run(g, inputs, runtime)
    np.testing.assert_array_equal(got, expected(RUNTIMES[runtime].add))
    assert any(np.any(expected(r.add) != got) for r in RUNTIMES.values() if r.add != RUNTIMES[runtime].add)


@pytest.mark.parametrize("runtime", list(RUNTIMES))
@pytest.mark.parametrize("kind", ["LOGISTIC", "TANH"])
def test_lookup_tables_bit_exact(runtime, kind):
    g, inputs, expected = table_graph(kind)
    np.testing.assert_array_equal(run(g, inputs, runtime), expected(runtime))


def test_quantize_op_bit_exact():
    """QUANTIZE (float -> int8) in LiteRT and QuantizeLinear in ONNX Runtime, ties included."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    from mnss_kit.quantize.runtime import OnnxRunner

    rng = np.random.default_rng(0)
    scale, zp = np.float32(0.03), 0
    x = (rng.normal(size=(1, 20, 20, 1)) * 2).astype(np.float32)
    x.flat[:200] = (np.arange(200) - 100 + 0.5).astype(np.float32) * scale  # near-ties
    xf = Tensor("x", x.shape, "float32", channel_order=np.arange(1))
    y = act("y", x.shape, scale, zp)
    g = Graph({"x": xf, "y": y}, [Op("QUANTIZE", ["x"], ["y"])], ["x"], ["y"])
    model = to_tflite(g)
    for runtime in runtime_names("litert"):
        got = TfliteRunner(model, runtime).run([x])["y"]
        np.testing.assert_array_equal(got, vector.quantize(x, (scale, zp), runtime))
    node = helper.make_node("QuantizeLinear", ["x", "s", "z"], ["y"])
    graph = helper.make_graph([node], "q", [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 1, 20, 20])],
                              [helper.make_tensor_value_info("y", TensorProto.INT8, [1, 1, 20, 20])],
                              initializer=[numpy_helper.from_array(scale, "s"), numpy_helper.from_array(np.int8(zp), "z")])
    m = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 21)], ir_version=10)
    got = OnnxRunner(m).run([x])["y"]
    expected = vector.quantize(x, (scale, zp), "ort-cpu")
    np.testing.assert_array_equal(got, expected)
    assert np.any(expected != vector.quantize(x, (scale, zp), "tflite-ref"))
    onnx.checker.check_model(m)
