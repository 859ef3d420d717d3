"""Per-layer sensitivity, 16-bit activations for the most sensitive tensors, and short QAT."""

import numpy as np

from mnss_kit.quantize.fakequant import GraphModule, finetune
from mnss_kit.quantize.graph import op_graph
from mnss_kit.quantize.onnx_writer import to_onnx
from mnss_kit.quantize.params import int16_blocker, quantize_graph
from mnss_kit.ops.runtimes import runtime_names
from mnss_kit.quantize.runtime import OnnxRunner, TfliteRunner, dequantize_tensor, quantize_inputs
from mnss_kit.quantize.sensitivity import choose_int16, only_layer_psnr, tensor_sqnr
from mnss_kit.quantize.tflite_writer import to_tflite

from .conftest import sqnr


def test_sqnr_and_single_layer_psnr(recon):
    samples = recon.samples[:2]
    per_tensor, float_outputs = tensor_sqnr(recon.float_graph, recon.graph, recon.tflite, samples)
    assert set(per_tensor) == set(recon.graph.activations())
    assert all(20 < v < 80 for v in per_tensor.values())
    only = only_layer_psnr(recon.graph, samples, float_outputs)
    out = recon.graph.outputs[0]
    lite = TfliteRunner(recon.tflite, "tflite-ref")
    full = [dequantize_tensor(recon.graph, out, lite.run(quantize_inputs(recon.graph, s))[out]) for s in samples]
    full_psnr = 10 * np.log10(1.0 / np.mean((np.concatenate(full) - np.concatenate([f[out] for f in float_outputs])) ** 2))
    # one quantized tensor alone hurts less than all of them together
    assert min(only.values()) >= full_psnr - 0.5


def test_int16_for_sensitive_tensors_runs_everywhere(gates):
    sqnr8, float_outputs = tensor_sqnr(gates.float_graph, gates.graph, gates.tflite, gates.samples[:2])
    only = only_layer_psnr(gates.graph, gates.samples[:2], float_outputs)
    chosen, skipped = choose_int16(gates.graph, only, 2)
    assert len(chosen) == 2 and set(chosen).isdisjoint([*gates.graph.inputs, *gates.graph.outputs])
    assert skipped and all(reason.endswith("the GPU <-> NPU boundary is int8") for reason in skipped.values())  # x, add
    g16 = quantize_graph(gates.float_graph, gates.ranges, int16=set(chosen))
    for name in chosen:
        t = g16.tensors[name]
        assert t.dtype == "int16" and t.zero_point == 0
    assert any(op.kind == "QUANTIZE" for op in g16.ops)
    model = to_tflite(g16)
    names = g16.activations()
    q = quantize_inputs(g16, gates.samples[0])
    ref = TfliteRunner(model, "tflite-ref", preserve_all=True).run(q, names)
    for op in g16.ops:  # given the same inputs, each op agrees within 1 LSB of its output type
        sub = op_graph(g16, op)
        inputs = [ref[n] for n in sub.inputs]
        a = TfliteRunner(to_tflite(sub), "tflite-ref").run(inputs)[op.outputs[0]]
        b = OnnxRunner(to_onnx(sub)).run(inputs)[op.outputs[0]]
        # LiteRT's int16 TANH is its own approximation: a few int16 LSB (about 1e-4 of the range) from float
        allowed = 4 if op.kind == "TANH" and g16.tensors[op.outputs[0]].dtype == "int16" else 1
        assert np.abs(a.astype(int) - b.astype(int)).max() <= allowed, op.kind
    for runtime in runtime_names("litert"):
        out = TfliteRunner(model, runtime).run(q)[g16.outputs[0]]
        assert out.shape == ref[g16.outputs[0]].shape
    # the 16-bit tensors themselves are much closer to float
    sqnr16, _ = tensor_sqnr(gates.float_graph, g16, model, gates.samples[:2])
    for name in chosen:
        assert sqnr16[name] > sqnr8[name] + 1.0  # less than 16 bits alone would give: upstream int8 error reaches it


def test_int16_blockers(recon):
    assert "SPACE_TO_DEPTH" in int16_blocker(recon.graph, "down")
    assert "DEPTH_TO_SPACE" in int16_blocker(recon.graph, "tail")
    assert "clamp" in int16_blocker(recon.graph, "add")
    assert int16_blocker(recon.graph, "body") is None
    chosen, skipped = choose_int16(recon.graph, {"add": 10.0, "tail": 20.0, "body": 30.0, "head": 40.0}, 1)
    assert chosen == ["body"] and set(skipped) == {"add", "tail"}


def test_fake_quant_executor_matches_litert(recon):
    xs = recon.example
    fq = GraphModule(recon.graph, fake_quant=True)(*xs).detach().numpy().transpose(0, 2, 3, 1)
    out = recon.graph.outputs[0]
    lite = dequantize_tensor(recon.graph, out, TfliteRunner(recon.tflite, "tflite-ref").run(quantize_inputs(recon.graph, [x.numpy() for x in xs]))[out])
    assert np.abs(fq - lite).max() <= 2 * float(recon.graph.tensors[out].scale)


def test_qat_keeps_activation_parameters(recon):
    trained, losses = finetune(recon.graph, recon.module, recon.samples, steps=40, lr=3e-4)
    for name in recon.graph.activations():
        assert trained.tensors[name].params() == recon.graph.tensors[name].params()
    changed = [n for n in recon.graph.constants() if not np.array_equal(trained.tensors[n].data, recon.graph.tensors[n].data)]
    assert changed
    assert np.mean(losses[-10:]) < np.mean(losses[:10])
    ref = recon.module(*recon.example).detach().numpy().transpose(0, 2, 3, 1)
    out = trained.outputs[0]
    got = dequantize_tensor(trained, out, TfliteRunner(to_tflite(trained), "tflite-ref").run(quantize_inputs(trained, [x.numpy() for x in recon.example]))[out])
    assert sqnr(ref, got) > 35.0
