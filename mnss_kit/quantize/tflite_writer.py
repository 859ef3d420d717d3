"""Quantized Graph -> ``npu.tflite``, written with the LiteRT flatbuffer schema (no TensorFlow).

NHWC, integer inputs and outputs, every scale and zero point copied from the
graph.  Ops and their versions come from ``mnss_kit.ops.npu_ops.NPU_OPS``.
"""

from __future__ import annotations

import flatbuffers
import numpy as np
from ai_edge_litert import schema_py_generated as schema

from ..ops.npu_ops import NPU_OPS
from .graph import Graph, Op

FILE_IDENTIFIER = b"TFL3"
SCHEMA_VERSION = 3

TENSOR_TYPES = {
    "float32": schema.TensorType.FLOAT32,
    "int8": schema.TensorType.INT8,
    "int16": schema.TensorType.INT16,
    "int32": schema.TensorType.INT32,
    "int64": schema.TensorType.INT64,
}
ACTIVATIONS = {
    "none": schema.ActivationFunctionType.NONE,
    "clamp": schema.ActivationFunctionType.NONE,  # enforced by the output range (checked by params)
    "relu": schema.ActivationFunctionType.RELU,
    "relu6": schema.ActivationFunctionType.RELU6,
    "relu_n1_to_1": schema.ActivationFunctionType.RELU_N1_TO_1,
}


def to_tflite(graph: Graph, expose: list[str] | None = None, description: str = "mnss-kit npu stage") -> bytes:
    """Serialize a quantized graph; ``expose`` adds intermediate tensors as extra outputs.

    A float graph is written too (float32 throughout, for latency comparisons);
    its general clamps have no fused form and are left out.
    """
    return _Writer(graph).build(expose or [], description)


class _Writer:
    def __init__(self, graph: Graph):
        self.g = graph
        self.buffers = [schema.BufferT()]  # buffer 0: the empty sentinel
        self.tensors: list = []
        self.index: dict[str, int] = {}
        self.opcodes: list = []
        self.opcode_index: dict[tuple[int, int], int] = {}

    def buffer(self, data: np.ndarray | None) -> int:
        b = schema.BufferT()
        if data is not None:
            b.data = np.frombuffer(np.ascontiguousarray(data).tobytes(), dtype=np.uint8)
        self.buffers.append(b)
        return len(self.buffers) - 1

    def tensor(self, name: str, wide_bias: bool = False) -> int:
        """Index of tensor ``name``; ``wide_bias`` stores an int32 bias as int64 (16x8 convolutions)."""
        if name in self.index:
            return self.index[name]
        t = self.g.tensors[name]
        data = t.data if t.data is not None else t.float_data  # a float graph stores float constants
        tt = schema.TensorT()
        tt.name = name
        tt.shape = np.array(t.shape, dtype=np.int32)
        tt.type = TENSOR_TYPES[t.dtype]
        if wide_bias and t.dtype == "int32":
            data = t.data.astype(np.int64)
            tt.type = TENSOR_TYPES["int64"]
        if t.scale is not None:
            q = schema.QuantizationParametersT()
            q.scale = np.atleast_1d(np.asarray(t.scale, np.float32))
            q.zeroPoint = np.atleast_1d(np.asarray(t.zero_point, np.int64))
            if t.per_channel:
                q.zeroPoint = np.zeros(len(q.scale), np.int64)
                q.quantizedDimension = t.axis
            tt.quantization = q
        tt.buffer = self.buffer(data if t.is_constant else None)
        return self._add(name, tt)

    def raw_constant(self, name: str, data: np.ndarray) -> int:
        tt = schema.TensorT()
        tt.name = name
        tt.shape = np.array(data.shape, dtype=np.int32)
        tt.type = TENSOR_TYPES[data.dtype.name]
        tt.buffer = self.buffer(data)
        return self._add(name, tt)

    def _add(self, name: str, tt) -> int:
        self.tensors.append(tt)
        self.index[name] = len(self.tensors) - 1
        return self.index[name]

    def opcode(self, op: Op) -> int:
        code = getattr(schema.BuiltinOperator, op.kind)
        dtypes = {self.g.tensors[n].dtype for n in op.inputs + op.outputs}
        if dtypes == {"float32"}:
            version = 1
        else:
            npu_op = NPU_OPS[op.kind]
            version = npu_op.version_int16 if "int16" in dtypes else npu_op.version
        key = (code, version)
        if key not in self.opcode_index:
            oc = schema.OperatorCodeT()
            oc.builtinCode = code
            oc.deprecatedBuiltinCode = min(code, schema.BuiltinOperator.PLACEHOLDER_FOR_GREATER_OP_CODES)
            oc.version = version
            self.opcodes.append(oc)
            self.opcode_index[key] = len(self.opcodes) - 1
        return self.opcode_index[key]

    def operator(self, op: Op):
        o = schema.OperatorT()
        o.opcodeIndex = self.opcode(op)
        # 16x8 convolutions take an int64 bias in LiteRT (an int32 one is misread)
        wide = op.kind in ("CONV_2D", "DEPTHWISE_CONV_2D") and self.g.tensors[op.inputs[0]].dtype == "int16"
        inputs = [self.tensor(n, wide_bias=wide and i == 2) for i, n in enumerate(op.inputs)]
        opts, opts_type = self.options(op, inputs)
        o.inputs = np.array(inputs, dtype=np.int32)
        o.outputs = np.array([self.tensor(n) for n in op.outputs], dtype=np.int32)
        if opts is not None:
            o.builtinOptions, o.builtinOptionsType = opts, opts_type
        return o

    def options(self, op: Op, inputs: list[int]):
        k, a = op.kind, op.options
        B = schema.BuiltinOptions
        if k in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            o = schema.Conv2DOptionsT() if k == "CONV_2D" else schema.DepthwiseConv2DOptionsT()
            o.padding = getattr(schema.Padding, a["padding"])
            o.strideH, o.strideW = a["stride"]
            o.dilationHFactor, o.dilationWFactor = a["dilation"]
            o.fusedActivationFunction = ACTIVATIONS[a["activation"]]
            if k == "DEPTHWISE_CONV_2D":
                o.depthMultiplier = a.get("depth_multiplier", 1)
                return o, B.DepthwiseConv2DOptions
            return o, B.Conv2DOptions
        if k == "ADD":
            o = schema.AddOptionsT()
            o.fusedActivationFunction = ACTIVATIONS[a["activation"]]
            o.potScaleInt16 = False  # general int16 scales, not only powers of two
            return o, B.AddOptions
        if k == "MUL":
            o = schema.MulOptionsT()
            o.fusedActivationFunction = ACTIVATIONS[a["activation"]]
            return o, B.MulOptions
        if k == "CONCATENATION":
            o = schema.ConcatenationOptionsT()
            o.axis = a["axis"]
            return o, B.ConcatenationOptions
        if k == "AVERAGE_POOL_2D":
            o = schema.Pool2DOptionsT()
            o.padding = getattr(schema.Padding, a["padding"])
            o.strideH, o.strideW = a["stride"]
            o.filterHeight, o.filterWidth = a["kernel"]
            return o, B.Pool2DOptions
        if k == "RESIZE_BILINEAR":
            inputs.append(self.raw_constant(f"{op.outputs[0]}.size", np.array(a["size"], np.int32)))
            o = schema.ResizeBilinearOptionsT()
            o.alignCorners, o.halfPixelCenters = a["align_corners"], a["half_pixel_centers"]
            return o, B.ResizeBilinearOptions
        if k in ("DEPTH_TO_SPACE", "SPACE_TO_DEPTH"):
            o = schema.DepthToSpaceOptionsT() if k == "DEPTH_TO_SPACE" else schema.SpaceToDepthOptionsT()
            o.blockSize = a["block_size"]
            return o, B.DepthToSpaceOptions if k == "DEPTH_TO_SPACE" else B.SpaceToDepthOptions
        if k == "PAD":
            t, b, l, r = a["pads"]
            inputs.append(self.raw_constant(f"{op.outputs[0]}.paddings", np.array([[0, 0], [t, b], [l, r], [0, 0]], np.int32)))
            return schema.PadOptionsT(), B.PadOptions
        return None, None

    def build(self, expose: list[str], description: str) -> bytes:
        for name in self.g.inputs:
            self.tensor(name)
        operators = [self.operator(op) for op in self.g.ops]
        sg = schema.SubGraphT()
        sg.name = "main"
        sg.tensors = self.tensors
        sg.inputs = np.array([self.index[n] for n in self.g.inputs], dtype=np.int32)
        outputs = list(self.g.outputs) + [n for n in expose if n not in self.g.outputs]
        sg.outputs = np.array([self.index[n] for n in outputs], dtype=np.int32)
        sg.operators = operators
        model = schema.ModelT()
        model.version = SCHEMA_VERSION
        model.description = description
        model.subgraphs = [sg]
        model.operatorCodes = self.opcodes
        model.buffers = self.buffers
        builder = flatbuffers.Builder(1 << 16)
        builder.Finish(model.Pack(builder), file_identifier=FILE_IDENTIFIER)
        return bytes(builder.Output())
