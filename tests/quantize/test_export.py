"""npu.tflite and npu_qdq.onnx: same parameters, same integers (within 1 LSB), close to float, int8 rules."""

import numpy as np
import onnx
import pytest
import torch
from ai_edge_litert import schema_py_generated as schema
from onnx import numpy_helper

from mnss_kit.export.npu_files import parse_tflite
from mnss_kit.quantize.graph import op_graph
from mnss_kit.quantize.onnx_writer import to_onnx
from mnss_kit.ops.runtimes import runtime_names
from mnss_kit.quantize.runtime import OnnxRunner, QuantizedStage, TfliteRunner, dequantize_tensor, quantize_inputs, swap_stage

from .conftest import sqnr


def test_scales_and_zero_points_identical_in_both_files(recon):
    model = parse_tflite(recon.tflite)
    sg = model.subgraphs[0]
    onnx_model = onnx.load_from_string(to_onnx(recon.graph).SerializeToString())
    inits = {i.name: numpy_helper.to_array(i) for i in onnx_model.graph.initializer}
    checked = 0
    for t in sg.tensors:
        name = t.name.decode()
        if name not in recon.graph.tensors:
            continue  # shape constants of RESIZE / PAD
        g = recon.graph.tensors[name]
        np.testing.assert_array_equal(np.asarray(t.quantization.scale, np.float32), np.atleast_1d(np.float32(g.scale)))
        if not g.is_constant:
            assert int(t.quantization.zeroPoint[0]) == g.zero_point
            assert float(inits[f"{name}.scale"]) == np.float32(g.scale) and int(inits[f"{name}.zero_point"]) == g.zero_point
        else:
            np.testing.assert_array_equal(inits[f"{name}.scale"], np.asarray(g.scale, np.float32))
        checked += 1
    assert checked == len(recon.graph.tensors)


@pytest.mark.parametrize("fixture", ["recon", "gates"])
def test_int8_spec_rules(fixture, request):
    q = request.getfixturevalue(fixture)
    g = q.graph
    for op in g.ops:
        out = g.tensors[op.outputs[0]]
        if op.kind == "CONCATENATION":
            assert all(g.tensors[n].params() == out.params() for n in op.inputs)
        if op.kind in ("DEPTH_TO_SPACE", "SPACE_TO_DEPTH", "AVERAGE_POOL_2D", "RESIZE_BILINEAR", "PAD"):
            assert g.tensors[op.inputs[0]].params() == out.params()
        if op.kind == "LOGISTIC":
            assert out.params() == (1 / 256, -128)
        if op.kind == "TANH":
            assert out.params() == (1 / 128, 0)
        if op.kind in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            w, b = g.tensors[op.inputs[1]], g.tensors[op.inputs[2]]
            assert w.data.dtype == np.int8 and np.abs(w.data.astype(int)).max() <= 127 and b.data.dtype == np.int32
            assert w.axis == (0 if op.kind == "CONV_2D" else 3)
    model = parse_tflite(q.tflite)
    versions = {(c.builtinCode, c.version) for c in model.operatorCodes}
    assert all(v == 1 for code, v in versions if code == schema.BuiltinOperator.DEPTH_TO_SPACE)
    sg = model.subgraphs[0]
    assert all(sg.tensors[i].type == schema.TensorType.INT8 for i in list(sg.inputs) + list(sg.outputs))


def test_every_int8_tensor_agrees_within_one_lsb(recon):
    names = recon.graph.activations()
    lite = TfliteRunner(recon.tflite, "tflite-ref", preserve_all=True)
    ort = OnnxRunner(to_onnx(recon.graph, expose=names))
    differing = 0
    for sample in recon.samples:
        q = quantize_inputs(recon.graph, sample)
        a, b = lite.run(q, names), ort.run(q)
        for n in names:
            assert a[n].shape == b[n].shape
            diff = np.abs(a[n].astype(int) - b[n].astype(int))
            assert diff.max() <= 1, n
            differing += np.count_nonzero(diff)
    assert differing < 0.01 * sum(np.prod(recon.graph.tensors[n].shape) for n in names) * len(recon.samples)


def test_every_op_agrees_within_one_lsb_given_the_same_inputs(gates):
    """Pooling and resizing round ties differently in each runtime, so compare op by op."""
    g = gates.graph
    names = g.activations()
    q = quantize_inputs(g, gates.samples[0])
    values = TfliteRunner(gates.tflite, "tflite-ref", preserve_all=True).run(q, names)
    from mnss_kit.quantize.tflite_writer import to_tflite

    for op in g.ops:
        sub = op_graph(g, op)
        inputs = [values[n] for n in sub.inputs]
        a = TfliteRunner(to_tflite(sub), "tflite-ref").run(inputs)[op.outputs[0]]
        b = OnnxRunner(to_onnx(sub)).run(inputs)[op.outputs[0]]
        assert np.abs(a.astype(int) - b.astype(int)).max() <= 1, op.kind


@pytest.mark.parametrize("fixture", ["recon", "gates"])
def test_all_runtimes_run_and_stay_close_to_float(fixture, request):
    q = request.getfixturevalue(fixture)
    ref = q.module(*q.example).detach().numpy().transpose(0, 2, 3, 1)
    out = q.graph.outputs[0]
    runners = [TfliteRunner(q.tflite, r) for r in runtime_names("litert")] + [OnnxRunner(to_onnx(q.graph))]
    for runner in runners:
        got = dequantize_tensor(q.graph, out, runner.run(quantize_inputs(q.graph, [x.numpy() for x in q.example]))[out])
        assert sqnr(ref, got) > 35.0


def test_swapped_stage_runs_inside_a_float_model(recon):
    class Pipeline(torch.nn.Module):
        def __init__(self, recon_module):
            super().__init__()
            self.recon = recon_module

        def forward(self, history, aa):
            return self.recon(history, aa) * 0.5

    pipeline = Pipeline(recon.module)
    xs = [torch.cat([x, x], dim=0) for x in recon.example]  # batch 2: the stage runs sample by sample
    float_out = pipeline(*xs).detach()
    original = swap_stage(pipeline, "recon", QuantizedStage.build(recon.graph, recon.tflite, "xnnpack"))
    int8_out = pipeline(*xs)
    assert original is recon.module and int8_out.shape == float_out.shape
    assert sqnr(float_out.numpy(), int8_out.numpy()) > 35.0
    onnx_stage = QuantizedStage.build(recon.graph, to_onnx(recon.graph).SerializeToString(), "ort-cpu")
    assert torch.abs(onnx_stage(*xs) - pipeline.recon(*xs)).max() <= 2 * float(recon.graph.tensors[recon.graph.outputs[0]].scale)


def test_onnxruntime_equals_the_ort_cpu_kernels_on_this_cpu(recon):
    """npu_qdq.onnx in ONNX Runtime, as the quantize stage runs it, equals the emulator's ``ort-cpu``
    kernels bit for bit.  Without int8 QDQ fusion, ONNX Runtime on an x86 CPU without VNNI runs
    some of these convolutions in saturating u8 x s8 kernels and 597 of the 768 outputs differ."""
    from mnss_kit.emulate.npu import open_npu

    inputs = quantize_inputs(recon.graph, [x.numpy() for x in recon.example])
    out = recon.graph.outputs[0]
    runner = OnnxRunner(to_onnx(recon.graph))
    assert runner.session.get_session_options().get_session_config_entry("session.qdqisint8allowed") == "1"
    got = runner.run(inputs)[out]
    emulated = open_npu(recon.tflite, "ort-cpu", "numpy").run(dict(zip(recon.graph.inputs, inputs)))[out]
    np.testing.assert_array_equal(got, emulated)
