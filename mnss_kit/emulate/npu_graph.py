"""``npu.tflite`` read into plain data the emulator interprets op by op.

Tensors are read by the toolkit's one NPU file reader (``export.npu_files``); this module adds
the operators, in execution order, with their options normalized.  Every problem
a user can cause (missing, truncated or foreign file, an operator or option
the emulator does not implement, a tensor without quantization) is a
``UserError`` naming the file and the operator or tensor.

Layout and quantization are the file's own: activations NHWC with one
``(scale, zero_point)`` pair, CONV_2D weights OHWI and DEPTHWISE_CONV_2D
weights 1HWO with one scale per output channel, int32 biases.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..export.npu_files import NpuTensor, parse_tflite, text, tflite_tensors
from ..ops.npu_ops import NPU_OPS

# operator -> number of activation (non-constant) inputs it takes; constants follow them
SUPPORTED_OPS = {name: op.activation_inputs for name, op in NPU_OPS.items()}
ACTIVATIONS = {0: "none", 1: "relu", 2: "relu_n1_to_1", 3: "relu6"}
EMULATED_TYPES = ("float32", "int32", "int64", "int16", "int8")


@dataclass
class NpuOp:
    """One operator: its kind (``BuiltinOperator`` name), tensor names and normalized options."""

    index: int
    kind: str
    inputs: list[str]
    outputs: list[str]
    options: dict = field(default_factory=dict)

    def describe(self) -> str:
        return f"operator {self.index} ({self.kind} -> '{self.outputs[0]}')"


@dataclass
class NpuGraph:
    """Tensors by name, operators in execution order, graph inputs and outputs."""

    tensors: dict[str, NpuTensor]
    ops: list[NpuOp]
    inputs: list[str]
    outputs: list[str]
    source: str = "npu.tflite"

    def execution_order(self) -> list[str]:
        """Activation tensors as they become available: inputs, then each operator's outputs."""
        names = list(self.inputs)
        for op in self.ops:
            names.extend(n for n in op.outputs if n not in names)
        return names


def read_npu_graph(path_or_bytes: str | Path | bytes, source: str | None = None) -> NpuGraph:
    """Parse a ``.tflite`` file (path or bytes) into an :class:`NpuGraph`; ``UserError`` on any problem."""
    if isinstance(path_or_bytes, bytes):
        data, source = path_or_bytes, source or "npu.tflite"
    else:
        path = Path(path_or_bytes)
        source = source or str(path)
        if not path.is_file():
            raise UserError(f"{source}: missing")
        data = path.read_bytes()
    model = _parse(data, source)
    return _Reader(model, data, source).graph()


def _parse(data: bytes, source: str):
    model = parse_tflite(data, source)
    if len(model.subgraphs) > 1:
        raise UserError(f"{source}: has {len(model.subgraphs)} subgraphs; the emulator runs single-subgraph models")
    return model


class _Reader:
    def __init__(self, model, raw: bytes, source: str):
        from ai_edge_litert import schema_py_generated as schema

        self.schema = schema
        self.model = model
        self.source = source
        self.sub = model.subgraphs[0]
        self.op_names = {v: k for k, v in vars(schema.BuiltinOperator).items() if not k.startswith("_")}
        self.tensors = tflite_tensors(model, raw, source)
        for t in self.tensors:
            if t.dtype not in EMULATED_TYPES:
                raise self.fail(f"tensor '{t.name}' has element type {t.dtype}, which the emulator does not handle")
        self.by_name = {t.name: t for t in self.tensors}

    def fail(self, message: str) -> UserError:
        return UserError(f"{self.source}: {message}")

    def graph(self) -> NpuGraph:
        names = [t.name for t in self.tensors]
        if len(set(names)) != len(names):
            dup = next(n for n in names if names.count(n) > 1)
            raise self.fail(f"tensor name '{dup}' is used twice; the emulator addresses tensors by name")
        ops = [self.operator(i, o) for i, o in enumerate(self.sub.operators or [])]
        inputs = [names[i] for i in self.sub.inputs]
        outputs = [names[i] for i in self.sub.outputs]
        return NpuGraph({t.name: t for t in self.tensors}, ops, inputs, outputs, self.source)

    def operator(self, index: int, o) -> NpuOp:
        code = self.model.operatorCodes[o.opcodeIndex]
        builtin = max(int(code.builtinCode), int(code.deprecatedBuiltinCode))
        kind = self.op_names.get(builtin, f"builtin code {builtin}")
        if code.customCode:
            kind = f"custom op '{text(code.customCode)}'"
        ins = [self.tensors[i].name if i >= 0 else "" for i in o.inputs]
        outs = [self.tensors[i].name for i in o.outputs]
        op = NpuOp(index, kind, ins, outs)
        if kind not in SUPPORTED_OPS:
            raise self.fail(f"{op.describe()}: the emulator does not implement {kind} "
                            f"(supported: {', '.join(SUPPORTED_OPS)})")
        op.options = self.options(op, o.builtinOptions)
        return op

    def activation(self, op: NpuOp, code: int) -> str:
        if code not in ACTIVATIONS:
            raise self.fail(f"{op.describe()}: fused activation {code} is not implemented by the emulator")
        return ACTIVATIONS[code]

    def stride(self, op: NpuOp, o) -> int:
        if o.strideH != o.strideW:
            raise self.fail(f"{op.describe()}: unequal strides {o.strideH}x{o.strideW} are not implemented by the emulator")
        return int(o.strideH)

    def padding(self, o) -> str:
        return "SAME" if o.padding == self.schema.Padding.SAME else "VALID"

    def constant(self, op: NpuOp, position: int, what: str) -> np.ndarray:
        if position >= len(op.inputs) or not op.inputs[position]:
            raise self.fail(f"{op.describe()}: missing {what} input")
        data = self.by_name[op.inputs[position]].data
        if data is None:
            raise self.fail(f"{op.describe()}: {what} ('{op.inputs[position]}') must be a constant")
        return data

    def options(self, op: NpuOp, o) -> dict:
        k = op.kind
        if k in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            if (o.dilationHFactor or 1) != 1 or (o.dilationWFactor or 1) != 1:
                raise self.fail(f"{op.describe()}: dilated convolutions are not implemented by the emulator")
            self.constant(op, 1, "weights")
            return {"stride": self.stride(op, o), "padding": self.padding(o), "activation": self.activation(op, o.fusedActivationFunction)}
        if k in ("ADD", "MUL"):
            return {"activation": self.activation(op, o.fusedActivationFunction if o is not None else 0)}
        if k == "CONCATENATION":
            return {"axis": int(o.axis), "activation": self.activation(op, o.fusedActivationFunction)}
        if k == "AVERAGE_POOL_2D":
            if o.filterHeight != o.filterWidth:
                raise self.fail(f"{op.describe()}: non-square pooling windows are not implemented by the emulator")
            return {"size": int(o.filterHeight), "stride": self.stride(op, o), "padding": self.padding(o),
                    "activation": self.activation(op, o.fusedActivationFunction)}
        if k == "RESIZE_BILINEAR":
            if o is not None and o.alignCorners:
                raise self.fail(f"{op.describe()}: align_corners=True is not implemented by the emulator")
            size = self.constant(op, 1, "size")
            return {"size": (int(size[0]), int(size[1])), "half_pixel_centers": bool(o is not None and o.halfPixelCenters)}
        if k in ("DEPTH_TO_SPACE", "SPACE_TO_DEPTH"):
            return {"block": int(o.blockSize)}
        if k == "PAD":
            return {"paddings": self.constant(op, 1, "paddings").astype(np.int64)}
        return {}
