"""The NPU stage of the frame loop: npu.tflite interpreted in numpy equals the runtime of its profile.

The graph is built here without torch (``recon_graph``): the shape of the reconstruction net
(space-to-depth, convolutions with ReLU, a depthwise conv, a skip concatenation, depth-to-space,
the residual add) with random int8 weights, written by the quantize stage's writers.  Over ten
recurrent frames (each output, perturbed, is the next input) every int8 tensor must be identical
between the numpy interpreter and LiteRT under the matching runtime, and a wrong runtime must
show differences.
"""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.emulate.npu import open_npu
from mnss_kit.emulate.npu_graph import read_npu_graph
from mnss_kit.errors import UserError
from mnss_kit.ops.int8.weights import bias_scales, quantize_bias, quantize_weights_per_channel
from mnss_kit.ops.runtimes import runtime_names
from mnss_kit.quantize.graph import Graph, Op, Tensor
from mnss_kit.quantize.onnx_writer import to_onnx
from mnss_kit.quantize.tflite_writer import to_tflite

LITERT_PROFILES = runtime_names("litert")
IMAGE_Q = (1.0 / 255.0, -128)  # display values in [0, 1]
RELU_Q = (3.0 / 255.0, -128)  # [0, 3]
SIGNED_Q = (6.0 / 255.0, 0)  # about [-3, 3]
RESIDUAL_Q = (2.0 / 255.0, 0)  # about [-1, 1]


def _act(name, shape, q) -> Tensor:
    return Tensor(name=name, shape=tuple(shape), dtype="int8", scale=np.float32(q[0]), zero_point=int(q[1]),
                  channel_order=np.arange(shape[3]))


def _conv(tensors, ops, rng, name, x, cout, q, activation, depthwise=False, k=3):
    xt = tensors[x]
    n, h, w, cin = xt.shape
    shape, axis, fan_in = ((1, k, k, cout), 3, k * k) if depthwise else ((cout, k, k, cin), 0, k * k * cin)
    w_float = (rng.normal(size=shape) * 1.6 / np.sqrt(fan_in)).astype(np.float32)
    wq, ws = quantize_weights_per_channel(w_float, axis)
    b_float = (rng.normal(size=cout) * 0.2).astype(np.float32)
    tensors[f"{name}.w"] = Tensor(f"{name}.w", shape, "int8", ws, np.zeros(cout, np.int64), axis, wq, w_float)
    tensors[f"{name}.b"] = Tensor(f"{name}.b", (cout,), "int32", bias_scales(xt.scale, ws), np.zeros(cout, np.int64), 0,
                                  quantize_bias(b_float, xt.scale, ws), b_float)
    tensors[name] = _act(name, (n, h, w, cout), q)
    kind = "DEPTHWISE_CONV_2D" if depthwise else "CONV_2D"
    ops.append(Op(kind, [x, f"{name}.w", f"{name}.b"], [name],
                  dict(stride=(1, 1), dilation=(1, 1), padding="SAME", activation=activation), source=name))
    return name


def recon_graph(height: int, width: int, channels: int = 16, seed: int = 0, scale: int = 2) -> Graph:
    """A quantized reconstruction-shaped graph: (1, H, W, 3) int8 image ``x`` -> (1, H, W, 3) int8 ``y``."""
    rng = np.random.default_rng(seed)
    h, w = height // scale, width // scale
    t = {"x": _act("x", (1, height, width, 3), IMAGE_Q), "s2d": _act("s2d", (1, h, w, 3 * scale * scale), IMAGE_Q)}
    ops = [Op("SPACE_TO_DEPTH", ["x"], ["s2d"], {"block_size": scale})]
    c0 = _conv(t, ops, rng, "head", "s2d", channels, RELU_Q, "relu")
    c1 = _conv(t, ops, rng, "body", c0, channels, RELU_Q, "relu")
    d = _conv(t, ops, rng, "dw", c1, channels, RELU_Q, "relu", depthwise=True)
    t["skip"] = _act("skip", (1, h, w, 2 * channels), RELU_Q)
    ops.append(Op("CONCATENATION", [d, c0], ["skip"], {"axis": 3}))
    f = _conv(t, ops, rng, "fuse", "skip", channels, SIGNED_Q, "none", k=1)
    r = _conv(t, ops, rng, "tail", f, 3 * scale * scale, RESIDUAL_Q, "none")
    t["d2s"] = _act("d2s", (1, height, width, 3), RESIDUAL_Q)
    ops.append(Op("DEPTH_TO_SPACE", [r], ["d2s"], {"block_size": scale}))
    t["y"] = _act("y", (1, height, width, 3), IMAGE_Q)
    ops.append(Op("ADD", ["x", "d2s"], ["y"], {"activation": "none"}))
    graph = Graph(t, ops, ["x"], ["y"])
    graph.validate()
    return graph


def recon_files(height: int, width: int, seed: int = 0) -> tuple[bytes, bytes]:
    """``npu.tflite`` and ``npu_qdq.onnx`` bytes of :func:`recon_graph`."""
    graph = recon_graph(height, width, seed=seed)
    return to_tflite(graph), to_onnx(graph).SerializeToString()


def recurrent_inputs(first: np.ndarray, step, frames: int, seed: int = 1):
    """Yield ``frames`` inputs: each is the previous output, shifted and perturbed (a moving camera)."""
    rng = np.random.default_rng(seed)
    x = first
    for _ in range(frames):
        yield x
        y = step(x)
        noise = rng.integers(-6, 7, size=y.shape)
        x = np.clip(np.roll(y, 1, axis=2).astype(np.int16) + noise, -128, 127).astype(np.int8)


@pytest.fixture(scope="module")
def files():
    return recon_files(48, 64)


@pytest.fixture(scope="module")
def first_input():
    rng = np.random.default_rng(7)
    return {"x": rng.integers(-128, 128, size=(1, 48, 64, 3)).astype(np.int8)}


def run_recurrent(npu, first, frames=10, keep_all=True):
    """Per frame, every tensor the NPU backend returns."""
    out = []

    def step(x):
        result = npu.run({"x": x}, keep_all=keep_all)
        out.append({"x": x, **result})
        return result["y"]

    for _ in recurrent_inputs(first["x"], step, frames):
        pass
    return out


@pytest.mark.parametrize("profile", LITERT_PROFILES)
def test_numpy_equals_litert_over_recurrent_frames(files, first_input, profile):
    tflite, _ = files
    numpy_npu = open_npu(tflite, profile, "numpy")
    litert = open_npu(tflite, profile, "litert")
    # drive both from the runtime's own outputs so each frame compares the same inputs
    expected = run_recurrent(litert, first_input)
    compared = 0
    for t, frame in enumerate(expected):
        got = numpy_npu.run({"x": frame["x"]}, keep_all=True)
        for name, value in frame.items():
            assert got[name].dtype == value.dtype, name
            bad = int(np.count_nonzero(got[name] != value))
            assert bad == 0, f"{profile}: frame {t} tensor '{name}': {bad} of {value.size} values differ"
            compared += value.size
    assert compared >= 10 * 48 * 64 * 3 * 2


def test_wrong_profile_is_detected(files, first_input):
    """Each runtime's outputs differ from the numpy interpreter under some other runtime."""
    tflite, _ = files
    for runtime in LITERT_PROFILES:
        expected = run_recurrent(open_npu(tflite, runtime, "litert"), first_input, keep_all=False)
        mismatches = {}
        for other in LITERT_PROFILES:
            npu = open_npu(tflite, other, "numpy")
            mismatches[other] = sum(int(np.count_nonzero(npu.run({"x": f["x"]})["y"] != f["y"])) for f in expected)
        assert mismatches[runtime] == 0
        assert max(mismatches.values()) > 0, f"{runtime}: no other runtime differs ({mismatches})"


def test_onnxruntime_backend_runs_close_to_the_tflite_reference(files, first_input):
    """Same graph, other rounding: most values agree, none by much (the differences compound over layers)."""
    tflite, onnx = files
    ort = open_npu(tflite, "ort-cpu", "onnxruntime", onnx=onnx)
    y_ort = ort.run(first_input)["y"]
    y_ref = open_npu(tflite, "tflite-ref", "numpy").run(first_input)["y"]
    assert y_ort.shape == y_ref.shape == (1, 48, 64, 3) and y_ort.dtype == np.int8
    diff = np.abs(y_ort.astype(np.int16) - y_ref)
    assert np.mean(diff > 0) < 0.1 and diff.max() <= 16


def test_numpy_equals_onnxruntime(files, first_input):
    tflite, onnx = files
    expected = run_recurrent(open_npu(tflite, "ort-cpu", "onnxruntime", onnx=onnx), first_input, keep_all=False)
    npu = open_npu(tflite, "ort-cpu", "numpy")
    for t, frame in enumerate(expected):
        assert np.array_equal(npu.run({"x": frame["x"]})["y"], frame["y"]), f"frame {t}"


def test_profile_and_backend_mismatch_are_user_errors(files):
    tflite, onnx = files
    with pytest.raises(UserError, match="LiteRT"):
        open_npu(tflite, "ort-cpu", "litert")
    with pytest.raises(UserError, match="ort-cpu"):
        open_npu(tflite, "tflite-ref", "onnxruntime", onnx=onnx)
    with pytest.raises(UserError, match="unknown NPU profile"):
        open_npu(tflite, "hexagon", "numpy")


def test_input_shape_and_dtype_are_checked(files):
    npu = open_npu(files[0], "tflite-ref", "numpy")
    with pytest.raises(UserError, match="NPU input 'x'"):
        npu.run({"x": np.zeros((1, 48, 64, 4), np.int8)})
    with pytest.raises(UserError, match="NPU input 'x'"):
        npu.run({"x": np.zeros((1, 48, 64, 3), np.float32)})
    with pytest.raises(UserError, match="missing"):
        npu.run({})


def test_graph_reader_keeps_names_order_and_quantization(files):
    graph = read_npu_graph(files[0])
    assert graph.inputs == ["x"] and graph.outputs == ["y"]
    assert [op.kind for op in graph.ops] == ["SPACE_TO_DEPTH", "CONV_2D", "CONV_2D", "DEPTHWISE_CONV_2D", "CONCATENATION",
                                            "CONV_2D", "CONV_2D", "DEPTH_TO_SPACE", "ADD"]
    assert graph.execution_order() == ["x", "s2d", "head", "body", "dw", "skip", "fuse", "tail", "d2s", "y"]
    x = graph.tensors["x"]
    assert x.qparams() == (np.float32(1.0 / 255.0), -128)
    w = graph.tensors["head.w"]
    assert w.data.dtype == np.int8 and w.data.shape == (16, 3, 3, 12) and w.scale.shape == (16,)
    assert graph.ops[1].options == {"stride": 1, "padding": "SAME", "activation": "relu"}
