"""The NPU stage: ``npu.tflite`` run op by op in numpy under a named runtime, or in the real one.

``--npu-profile`` names the runtime (``mnss_kit.ops.runtimes.RUNTIMES``) whose CPU kernels a
result must equal bit for bit: ``tflite-ref``, ``tflite-builtin``, ``xnnpack`` (LiteRT with one
of its op resolvers) or ``ort-cpu`` (ONNX Runtime CPU on npu_qdq.onnx at ORT_GRAPH_OPTIMIZATION).

Backends (``--npu-backend``): ``numpy`` interprets the graph with the kernels of
``emulate.kernels`` under the runtime's formulas; ``litert`` and ``onnxruntime`` run the
bundle's files in those engines.  All three take and return int8 NHWC arrays keyed by the
tensor names of ``npu.tflite`` (the QDQ ONNX file uses the same names).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UserError
from .interpreter import NumpyInterpreter
from ..ops.runtimes import RUNTIMES, Runtime
from .npu_graph import NpuGraph, read_npu_graph
from ..quantize.runtime import ort_session_options

BACKENDS = ("numpy", "litert", "onnxruntime")


def get_npu_profile(name: str) -> Runtime:
    """The runtime an ``--npu-profile`` names; ``UserError`` listing the names."""
    try:
        return RUNTIMES[name]
    except KeyError:
        raise UserError(f"unknown NPU profile '{name}' (one of: {', '.join(RUNTIMES)})") from None


def check_inputs(graph: NpuGraph, inputs: dict[str, np.ndarray]) -> None:
    """Every graph input present with its declared shape and dtype; ``UserError`` naming the tensor."""
    for name in graph.inputs:
        t = graph.tensors[name]
        if name not in inputs:
            raise UserError(f"NPU input '{name}' is missing")
        x = inputs[name]
        if tuple(x.shape) != t.shape or x.dtype != np.dtype(t.dtype):
            raise UserError(f"NPU input '{name}': got {x.dtype} {list(x.shape)}, {graph.source} expects {t.dtype} {list(t.shape)}")


class NumpyNpu:
    """``npu.tflite`` interpreted in numpy under the formulas of one runtime."""

    def __init__(self, graph: NpuGraph, profile: Runtime):
        self.graph = graph
        self.interpreter = NumpyInterpreter(graph, profile)

    def run(self, inputs: dict[str, np.ndarray], keep_all: bool = False) -> dict[str, np.ndarray]:
        """Graph inputs -> outputs (and, with ``keep_all``, every activation tensor) by name."""
        check_inputs(self.graph, inputs)
        return self.interpreter.run(inputs, keep_all)


class LiteRtNpu:
    """``npu.tflite`` in a LiteRT interpreter with the profile's op resolver (one thread)."""

    def __init__(self, graph: NpuGraph, model: bytes, profile: Runtime):
        if profile.litert_resolver is None:
            raise UserError(f"profile '{profile.name}' is not a LiteRT kernel set; use --npu-backend {profile.engine}")
        import warnings

        from ai_edge_litert.interpreter import Interpreter, OpResolverType

        self.graph = graph
        with warnings.catch_warnings():  # preserving intermediates is what a dump needs, not a mistake
            warnings.simplefilter("ignore", UserWarning)
            self.interpreter = Interpreter(model_content=model, num_threads=1,
                                           experimental_op_resolver_type=getattr(OpResolverType, profile.litert_resolver),
                                           experimental_preserve_all_tensors=True)
        try:
            self.interpreter.allocate_tensors()
        except (RuntimeError, ValueError) as e:
            raise UserError(f"{graph.source}: LiteRT cannot prepare the model ({str(e).strip().splitlines()[0]})") from None
        self.index = {d["name"]: d["index"] for d in self.interpreter.get_tensor_details()}
        ops = [d["op_name"] for d in self.interpreter._get_ops_details()]
        self.delegated = "DELEGATE" in ops  # intermediates inside a delegate are not readable

    def run(self, inputs: dict[str, np.ndarray], keep_all: bool = False) -> dict[str, np.ndarray]:
        check_inputs(self.graph, inputs)
        for name in self.graph.inputs:
            self.interpreter.set_tensor(self.index[name], np.ascontiguousarray(inputs[name]))
        self.interpreter.invoke()
        names = self.graph.outputs
        if keep_all and not self.delegated:
            names = self.graph.execution_order()
        elif keep_all:
            names = list(self.graph.inputs) + list(self.graph.outputs)
        return {n: self.interpreter.get_tensor(self.index[n]).copy() for n in names}


class OnnxNpu:
    """``npu_qdq.onnx`` in ONNX Runtime (CPU, one thread, pinned optimisation level).  NCHW inside."""

    def __init__(self, graph: NpuGraph, model: bytes, source: str = "npu_qdq.onnx"):
        import onnxruntime as ort

        self.graph = graph
        try:
            self.session = ort.InferenceSession(model, ort_session_options(), providers=["CPUExecutionProvider"])
        except Exception as e:  # onnxruntime raises its own exception types for bad models
            raise UserError(f"{source}: ONNX Runtime cannot load it ({str(e).strip().splitlines()[0][:200]})") from None
        inputs = [i.name for i in self.session.get_inputs()]
        if inputs != graph.inputs:
            raise UserError(f"{source}: inputs {inputs} differ from {graph.source} inputs {graph.inputs}")
        self.outputs = [o.name for o in self.session.get_outputs()]
        missing = [n for n in graph.outputs if n not in self.outputs]
        if missing:
            raise UserError(f"{source}: has no output '{missing[0]}' (an output of {graph.source})")

    def run(self, inputs: dict[str, np.ndarray], keep_all: bool = False) -> dict[str, np.ndarray]:
        """Graph inputs and outputs only: intermediates are fused away inside ONNX Runtime."""
        check_inputs(self.graph, inputs)
        feed = {n: np.ascontiguousarray(np.transpose(inputs[n], (0, 3, 1, 2))) for n in self.graph.inputs}
        results = dict(zip(self.outputs, self.session.run(None, feed)))
        out = {n: np.ascontiguousarray(np.transpose(results[n], (0, 2, 3, 1))) for n in self.graph.outputs}
        if keep_all:
            out = {**{n: inputs[n] for n in self.graph.inputs}, **out}
        return out


def open_npu(tflite: str | Path | bytes, profile: str, backend: str = "numpy", onnx: str | Path | bytes | None = None,
             graph: NpuGraph | None = None):
    """The NPU stage of ``tflite`` (path or bytes) under ``profile`` on ``backend``.

    ``onnx`` (path or bytes of the QDQ model) is needed for the ``onnxruntime`` backend.
    """
    p = get_npu_profile(profile)
    if backend not in BACKENDS:
        raise UserError(f"unknown NPU backend '{backend}' (one of: {', '.join(BACKENDS)})")
    graph = graph or read_npu_graph(tflite)
    if backend == "numpy":
        return NumpyNpu(graph, p)
    if backend == "litert":
        if p.engine != "litert":
            raise UserError(f"profile '{p.name}' runs in {p.engine}, not LiteRT; use --npu-backend {p.engine}")
        return LiteRtNpu(graph, _bytes(tflite, graph.source), p)
    if p.engine != "onnxruntime":
        ort = ", ".join(n for n, r in RUNTIMES.items() if r.engine == "onnxruntime")
        raise UserError(f"profile '{p.name}' is a LiteRT kernel set; use --npu-profile {ort} with --npu-backend onnxruntime")
    if onnx is None:
        raise UserError("the onnxruntime backend needs npu_qdq.onnx")
    source = "npu_qdq.onnx" if isinstance(onnx, bytes) else str(onnx)
    return OnnxNpu(graph, _bytes(onnx, source), source)


def _bytes(path_or_bytes, source: str) -> bytes:
    if isinstance(path_or_bytes, bytes):
        return path_or_bytes
    path = Path(path_or_bytes)
    if not path.is_file():
        raise UserError(f"{source}: missing")
    return path.read_bytes()
