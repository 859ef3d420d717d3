"""Run the written NPU stage (LiteRT or ONNX Runtime) and swap it into a float PyTorch model.

Runtimes are named as in ``mnss_kit.ops.runtimes.RUNTIMES``; :func:`open_runner` starts one.
Runners take and return NHWC arrays keyed by graph tensor name, so results from every runtime
compare directly; :class:`QuantizedStage` wraps one as an ``nn.Module`` with the float NCHW
interface of the module it replaces.
"""

from __future__ import annotations

import numpy as np

from ..ops.int8.quantize import dequantize, quantize
from ..ops.runtimes import DEFAULT_RUNTIME, get_runtime
from .graph import Graph


def quantize_inputs(graph: Graph, inputs_nchw: list[np.ndarray], runtime: str = DEFAULT_RUNTIME) -> list[np.ndarray]:
    """Float NCHW inputs -> integer NHWC arrays with each graph input's parameters, rounded as ``runtime`` rounds."""
    out = []
    for name, x in zip(graph.inputs, inputs_nchw, strict=True):
        t = graph.tensors[name]
        nhwc = np.ascontiguousarray(np.transpose(np.asarray(x, np.float32), (0, 2, 3, 1)))
        out.append(quantize(nhwc, t.scale, t.zero_point, t.dtype, runtime))
    return out


def dequantize_tensor(graph: Graph, name: str, q: np.ndarray) -> np.ndarray:
    t = graph.tensors[name]
    return dequantize(q, t.scale, t.zero_point)


class TfliteRunner:
    """LiteRT interpreter on ``npu.tflite`` bytes with the op resolver of a LiteRT ``runtime`` (e.g. ``tflite-ref``)."""

    def __init__(self, model: bytes, runtime: str = DEFAULT_RUNTIME, preserve_all: bool = False, num_threads: int = 1):
        from ai_edge_litert.interpreter import Interpreter, OpResolverType

        resolver = get_runtime(runtime).litert_resolver
        if resolver is None:
            raise ValueError(f"runtime {runtime!r} is not run by LiteRT")
        self.interpreter = Interpreter(
            model_content=model, experimental_op_resolver_type=getattr(OpResolverType, resolver),
            experimental_preserve_all_tensors=preserve_all, num_threads=num_threads
        )
        self.interpreter.allocate_tensors()
        self.details = {d["name"]: d["index"] for d in self.interpreter.get_tensor_details()}
        self.inputs = [d["index"] for d in self.interpreter.get_input_details()]
        self.outputs = [d["name"] for d in self.interpreter.get_output_details()]

    def run(self, inputs_nhwc: list[np.ndarray], names: list[str] | None = None) -> dict[str, np.ndarray]:
        """Run once; returns the outputs (and ``names``, readable with ``preserve_all``) as NHWC arrays."""
        for index, x in zip(self.inputs, inputs_nhwc, strict=True):
            self.interpreter.set_tensor(index, x)
        self.interpreter.invoke()
        return {n: self.interpreter.get_tensor(self.details[n]).copy() for n in list(self.outputs) + list(names or [])}


# ONNX Runtime fuses QDQ groups into QLinear kernels from this level on; pinned so results do not
# depend on the library default.  Layout-changing (ORT_ENABLE_ALL) passes are hardware specific.
ORT_GRAPH_OPTIMIZATION = "ORT_ENABLE_EXTENDED"
# A float model (calibration) keeps the library's default level.
FLOAT_GRAPH_OPTIMIZATION = "ORT_ENABLE_ALL"


def ort_session_options(num_threads: int = 1, level: str = ORT_GRAPH_OPTIMIZATION, qdq_int8: bool = True):
    """The session options of the ``ort-cpu`` runtime: one optimisation level, int8 QDQ fusion on.

    Without ``session.qdqisint8allowed`` ONNX Runtime on x86 rewrites some int8 QDQ convolutions
    to uint8 activations (its QDQS8ToU8 pass) and runs them in MLAS's u8 x s8 kernels, which on
    CPUs without VNNI sum pairs of products in saturating int16: results then depend on the CPU.
    With the flag the convolutions stay int8 x int8, whose integers do not.  ``qdq_int8=False``
    (ONNX Runtime's default path: faster on x86, not the ``ort-cpu`` runtime) is for timing only.
    """
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = num_threads
    options.inter_op_num_threads = 1
    options.log_severity_level = 3
    options.graph_optimization_level = getattr(ort.GraphOptimizationLevel, level)
    if qdq_int8:
        options.add_session_config_entry("session.qdqisint8allowed", "1")
    return options


class OnnxRunner:
    """ONNX Runtime (CPU) on an ONNX model written by :mod:`.onnx_writer` (NCHW inside).

    ``level``: a ``GraphOptimizationLevel`` name; QDQ models run at the ``ort-cpu`` one."""

    def __init__(self, model, num_threads: int = 1, level: str = ORT_GRAPH_OPTIMIZATION, qdq_int8: bool = True):
        import onnxruntime as ort

        data = model if isinstance(model, bytes) else model.SerializeToString()
        options = ort_session_options(num_threads, level, qdq_int8)
        self.session = ort.InferenceSession(data, options, providers=["CPUExecutionProvider"])
        self.input_names = [i.name for i in self.session.get_inputs()]
        self.output_names = [o.name for o in self.session.get_outputs()]

    def run(self, inputs_nhwc: list[np.ndarray]) -> dict[str, np.ndarray]:
        """Returns every output as NHWC, keyed by graph name (``.out`` suffixes removed)."""
        feed = {n: np.ascontiguousarray(np.transpose(x, (0, 3, 1, 2))) for n, x in zip(self.input_names, inputs_nhwc, strict=True)}
        results = self.session.run(None, feed)
        return {_graph_name(n): np.transpose(r, (0, 2, 3, 1)) for n, r in zip(self.output_names, results)}


def open_runner(runtime: str, tflite: bytes, onnx, **options):
    """A runner of ``runtime``: LiteRT on the ``tflite`` bytes or ONNX Runtime on the ``onnx`` model."""
    if get_runtime(runtime).engine == "onnxruntime":
        return OnnxRunner(onnx, **options)
    return TfliteRunner(tflite, runtime, **options)


def _graph_name(onnx_name: str) -> str:
    return onnx_name[: -len(".out")] if onnx_name.endswith(".out") else onnx_name


class QuantizedStage:
    """Factory for an ``nn.Module`` that runs the quantized graph in place of a float module.

    ``model``: ``npu.tflite`` bytes for a LiteRT ``runtime``, the QDQ ONNX model for ``ort-cpu``.
    Inputs are quantized with the rounding of that runtime, outputs dequantized; the module is
    float NCHW in and out, like the original.
    """

    @staticmethod
    def build(graph: Graph, model, runtime: str = DEFAULT_RUNTIME):
        import torch

        runner = open_runner(runtime, model, model)

        class _Stage(torch.nn.Module):
            placement = "npu"

            def forward(self, *inputs):
                # the graph has batch 1: run the samples one by one
                per_sample = [self.run_one([t[i : i + 1] for t in inputs]) for i in range(inputs[0].shape[0])]
                results = [torch.cat(parts, dim=0).to(inputs[0].device) for parts in zip(*per_sample)]
                return results[0] if len(results) == 1 else tuple(results)

            def run_one(self, inputs):
                arrays = [t.detach().cpu().float().numpy() for t in inputs]
                out = runner.run(quantize_inputs(graph, arrays, runtime))
                return [torch.from_numpy(np.ascontiguousarray(np.transpose(dequantize_tensor(graph, n, out[n]), (0, 3, 1, 2)))) for n in graph.outputs]

        return _Stage()


def swap_stage(model, attribute: str, replacement):
    """Replace ``model.<attribute>`` (a stage name) with ``replacement``; returns the original module."""
    original = getattr(model, attribute)
    setattr(model, attribute, replacement)
    return original
