"""One-op ``.tflite`` models written directly with the flatbuffer schema, and a runner.

Used to check the emulator's kernels against LiteRT: each test case builds a
model holding a single int8 operator with known scales and zero points, runs
it under one of LiteRT's kernel sets and compares with the numpy kernel.
No TensorFlow is needed: the schema's object API (``ModelT``, ``TensorT``,
...) is packed with a flatbuffers ``Builder`` and the file identifier
``TFL3``.  A test helper: the toolkit writes ``.tflite`` files only through
``mnss_kit.quantize.tflite_writer``; these one-op models set scales, zero points
and options directly, to test each kernel on its own.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from mnss_kit.ops.npu_ops import NPU_OPS
from mnss_kit.ops.runtimes import get_runtime

_TYPES = {"float32": 0, "int32": 2, "int8": 9}

# op name -> (BuiltinOptions member or None, options class name or None)
_OPTIONS = {name: (op.options, op.options and op.options + "T") for name, op in NPU_OPS.items()}

PADDING = {"SAME": 0, "VALID": 1}
ACTIVATION = {"NONE": 0, "RELU": 1, "RELU_N1_TO_1": 2, "RELU6": 3}


@dataclass
class TensorSpec:
    """One tensor of a one-op model.

    ``scale``/``zero_point`` are per tensor (one value) or per channel along
    ``quantized_dim``; ``data`` makes the tensor a constant (weights, bias,
    padding amounts).  Scales are stored as float32 in the file.
    """

    shape: Sequence[int]
    dtype: str = "int8"
    scale: Sequence[float] | None = None
    zero_point: Sequence[int] | None = None
    quantized_dim: int = 0
    data: np.ndarray | None = field(default=None, repr=False)


def single_op_model(op: str, inputs: Sequence[TensorSpec], outputs: Sequence[TensorSpec],
                    options: dict[str, Any] | None = None, version: int = 1) -> bytes:
    """Serialise a model with one operator ``op`` (a ``BuiltinOperator`` name).

    Non-constant inputs become the model inputs, in order.  ``options`` are
    fields of the op's ``*OptionsT`` (e.g. ``{"padding": PADDING["SAME"]}``).
    """
    import flatbuffers
    from ai_edge_litert import schema_py_generated as schema

    buffers = [schema.BufferT()]  # buffer 0 is the empty buffer by convention
    tensors = []
    for i, spec in enumerate(list(inputs) + list(outputs)):
        tensors.append(_tensor(schema, spec, f"t{i}", buffers))
    n_in = len(inputs)
    op_code = schema.OperatorCodeT()
    code = getattr(schema.BuiltinOperator, op)
    op_code.builtinCode = code
    op_code.deprecatedBuiltinCode = min(code, 127)
    op_code.version = version

    operator = schema.OperatorT()
    operator.opcodeIndex = 0
    operator.inputs = list(range(n_in))
    operator.outputs = list(range(n_in, n_in + len(outputs)))
    options_kind, options_class = _OPTIONS[op]
    if options_kind is not None:
        operator.builtinOptionsType = getattr(schema.BuiltinOptions, options_kind)
        opts = getattr(schema, options_class)()
        for key, value in (options or {}).items():
            if not hasattr(opts, key):
                raise ValueError(f"{options_class} has no field {key!r}")
            setattr(opts, key, value)
        operator.builtinOptions = opts

    subgraph = schema.SubGraphT()
    subgraph.tensors = tensors
    subgraph.inputs = [i for i, spec in enumerate(inputs) if spec.data is None]
    subgraph.outputs = list(operator.outputs)
    subgraph.operators = [operator]
    subgraph.name = "main"

    model = schema.ModelT()
    model.version = 3
    model.operatorCodes = [op_code]
    model.subgraphs = [subgraph]
    model.buffers = buffers
    model.description = "mnss-kit one-op kernel test"
    builder = flatbuffers.Builder(1024)
    builder.Finish(model.Pack(builder), file_identifier=b"TFL3")
    return bytes(builder.Output())


def _tensor(schema, spec: TensorSpec, name: str, buffers: list) -> Any:
    tensor = schema.TensorT()
    tensor.shape = [int(d) for d in spec.shape]
    tensor.type = _TYPES[spec.dtype]
    tensor.name = name
    tensor.buffer = 0
    if spec.data is not None:
        data = np.ascontiguousarray(spec.data, dtype=spec.dtype)
        if data.shape != tuple(tensor.shape):
            raise ValueError(f"constant {name}: data {data.shape} != shape {tuple(tensor.shape)}")
        buf = schema.BufferT()
        buf.data = np.frombuffer(data.tobytes(), dtype=np.uint8)
        buffers.append(buf)
        tensor.buffer = len(buffers) - 1
    if spec.scale is not None:
        quant = schema.QuantizationParametersT()
        quant.scale = [float(np.float32(s)) for s in np.atleast_1d(spec.scale)]
        zps = spec.zero_point if spec.zero_point is not None else [0] * len(quant.scale)
        quant.zeroPoint = [int(z) for z in np.atleast_1d(zps)]
        quant.quantizedDimension = spec.quantized_dim
        tensor.quantization = quant
    return tensor


class OneOpRunner:
    """A LiteRT interpreter for a model under one runtime (an ``ops.runtimes.RUNTIMES`` key)."""

    def __init__(self, model: bytes, runtime: str):
        from ai_edge_litert.interpreter import Interpreter, OpResolverType

        resolver_name = get_runtime(runtime).litert_resolver
        if resolver_name is None:
            raise ValueError(f"runtime {runtime!r} is not run by LiteRT")
        resolver = getattr(OpResolverType, resolver_name)
        self.interpreter = Interpreter(model_content=model, num_threads=1,
                                       experimental_op_resolver_type=resolver)
        self.interpreter.allocate_tensors()

    def delegated(self) -> bool:
        """True if a delegate (XNNPACK) took the operator."""
        names = [d["op_name"] for d in self.interpreter._get_ops_details()]
        return "DELEGATE" in names

    def __call__(self, *inputs: np.ndarray) -> list[np.ndarray]:
        interp = self.interpreter
        for detail, value in zip(interp.get_input_details(), inputs):
            interp.set_tensor(detail["index"], np.ascontiguousarray(value, dtype=detail["dtype"]))
        interp.invoke()
        return [interp.get_tensor(d["index"]) for d in interp.get_output_details()]


def run_one_op(model: bytes, runtime: str, *inputs: np.ndarray) -> np.ndarray:
    """Run a one-op model once and return its first output."""
    return OneOpRunner(model, runtime)(*inputs)[0]
