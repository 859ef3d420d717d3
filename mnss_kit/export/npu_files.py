"""What the NPU files of a bundle declare: tensors, shapes and quantization of ``npu.tflite`` and ``npu_qdq.onnx``.

Both readers return plain data so the manifest writer and ``bundle check`` compare like with
like.  The ``.tflite`` file is read with the flatbuffer schema that ships with ai-edge-litert
(``schema_py_generated``, object API), without an interpreter; the ONNX file with ``onnx``.
Quantization parameters in the QDQ ONNX file are the scale and zero-point initializers of the
``QuantizeLinear`` / ``DequantizeLinear`` nodes, keyed by the integer tensor they describe,
which carries the same name as in the ``.tflite`` file (both files are written from one graph).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import UserError

TFLITE_IDENTIFIER = b"TFL3"


@dataclass
class NpuTensor:
    """One tensor: ``shape`` in the file's own layout (NHWC for .tflite, NCHW for ONNX I/O).

    ``scale``/``zero_point`` are lists (one entry per tensor, or one per channel along ``axis``);
    empty when the tensor is not quantized.
    """

    name: str
    shape: list[int]
    dtype: str
    scale: list[float] = field(default_factory=list)
    zero_point: list[int] = field(default_factory=list)
    axis: int | None = None
    constant: bool = False

    def qparams(self) -> tuple[float, int]:
        """``(scale, zero_point)`` of a per-tensor quantized tensor."""
        if len(self.scale) != 1:
            raise ValueError(f"tensor {self.name} is not quantized per tensor")
        return self.scale[0], self.zero_point[0]


@dataclass
class NpuModel:
    inputs: list[str]
    outputs: list[str]
    tensors: dict[str, NpuTensor]

    def activations(self) -> list[NpuTensor]:
        """Quantized, non-constant tensors, in file order."""
        return [t for t in self.tensors.values() if not t.constant and t.scale]


def _tflite_type_names() -> dict[int, str]:
    from ai_edge_litert import schema_py_generated as schema

    return {v: k.lower() for k, v in vars(schema.TensorType).items() if not k.startswith("_")}


def parse_tflite(data: bytes, source: str = "npu.tflite"):
    """The flatbuffer object tree (``schema_py_generated.ModelT``) of a ``.tflite`` file with a subgraph."""
    from ai_edge_litert import schema_py_generated as schema

    if len(data) < 8 or data[4:8] != TFLITE_IDENTIFIER:
        raise UserError(f"{source} is not a TFLite flatbuffer (no 'TFL3' identifier)")
    try:
        model = schema.ModelT.InitFromPackedBuf(bytearray(data), 0)
    except Exception as e:  # a truncated flatbuffer raises from deep inside the generated code
        raise UserError(f"{source} is corrupt ({type(e).__name__} while reading the flatbuffer)") from None
    if not model.subgraphs:
        raise UserError(f"{source} has no subgraph")
    return model


def read_tflite(data: bytes, source: str = "npu.tflite") -> NpuModel:
    """Tensors, inputs and outputs of the first subgraph of a ``.tflite`` flatbuffer."""
    model = parse_tflite(data, source)
    graph = model.subgraphs[0]
    types = _tflite_type_names()
    tensors = {}
    for t in graph.tensors:
        name = t.name.decode() if isinstance(t.name, bytes) else t.name
        buffer = model.buffers[t.buffer] if model.buffers and t.buffer < len(model.buffers) else None
        constant = buffer is not None and buffer.data is not None and len(buffer.data) > 0
        q = t.quantization
        scale = [] if q is None or q.scale is None else [float(np.float32(s)) for s in q.scale]
        zps = [] if q is None or q.zeroPoint is None else [int(z) for z in q.zeroPoint]
        tensors[name] = NpuTensor(
            name=name,
            shape=[int(d) for d in (t.shape if t.shape is not None else [])],
            dtype=types.get(t.type, f"type{t.type}"),
            scale=scale,
            zero_point=zps,
            axis=int(q.quantizedDimension) if q is not None and len(scale) > 1 else None,
            constant=constant,
        )
    names = [graph.tensors[i].name for i in graph.inputs], [graph.tensors[i].name for i in graph.outputs]
    inputs, outputs = ([n.decode() if isinstance(n, bytes) else n for n in group] for group in names)
    return NpuModel(inputs, outputs, tensors)


_ONNX_TYPES = {1: "float32", 3: "int8", 2: "uint8", 5: "int16", 6: "int32", 7: "int64"}


def read_onnx(data: bytes, source: str = "npu_qdq.onnx") -> NpuModel:
    """Inputs and outputs (NCHW shapes) and the quantization of every Q/DQ'd tensor of a QDQ ONNX model."""
    import onnx
    from onnx import numpy_helper

    try:
        model = onnx.load_from_string(data)
    except Exception as e:  # protobuf's DecodeError and friends
        raise UserError(f"{source} is corrupt ({type(e).__name__} while parsing the protobuf)") from None
    graph = model.graph
    inits = {i.name: numpy_helper.to_array(i) for i in graph.initializer}
    tensors: dict[str, NpuTensor] = {}
    for value in list(graph.input) + list(graph.output):
        tt = value.type.tensor_type
        tensors[value.name] = NpuTensor(
            name=value.name,
            shape=[int(d.dim_value) for d in tt.shape.dim],
            dtype=_ONNX_TYPES.get(tt.elem_type, f"type{tt.elem_type}"),
        )
    for node in graph.node:
        if node.op_type not in ("QuantizeLinear", "DequantizeLinear") or len(node.input) < 3:
            continue
        integer = node.output[0] if node.op_type == "QuantizeLinear" else node.input[0]
        scale, zp = inits.get(node.input[1]), inits.get(node.input[2])
        if scale is None or zp is None:
            continue
        entry = tensors.setdefault(integer, NpuTensor(integer, [], str(zp.dtype)))
        entry.dtype = str(zp.dtype)
        entry.scale = [float(s) for s in np.atleast_1d(scale).astype(np.float32)]
        entry.zero_point = [int(z) for z in np.atleast_1d(zp)]
        if len(entry.scale) > 1:
            entry.axis = next((a.i for a in node.attribute if a.name == "axis"), 1)
        if integer in inits:
            entry.constant = True
            entry.shape = list(inits[integer].shape)
    return NpuModel([v.name for v in graph.input], [v.name for v in graph.output], tensors)


def nchw_to_nhwc(shape: list[int]) -> list[int]:
    n, c, h, w = shape
    return [n, h, w, c]
