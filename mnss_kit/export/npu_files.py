"""The one reader of the NPU files: tensors, shapes and quantization of ``npu.tflite`` and ``npu_qdq.onnx``.

The manifest writer, ``bundle check`` and the emulator (``emulate.npu_graph``, which adds the
operators) all read tensors through here, into one :class:`NpuTensor`.  The ``.tflite`` file is
read with the flatbuffer schema that ships with ai-edge-litert (``schema_py_generated``, object
API), without an interpreter; the ONNX file with ``onnx``.  Quantization parameters in the QDQ
ONNX file are the scale and zero-point initializers of the ``QuantizeLinear`` /
``DequantizeLinear`` nodes, keyed by the integer tensor they describe, which carries the same name
as in the ``.tflite`` file (both files are written from one graph).  Every problem with a file is a
``UserError`` naming it and the tensor.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import UserError

TFLITE_IDENTIFIER = b"TFL3"


@dataclass
class NpuTensor:
    """One tensor: ``shape`` in the file's own layout (NHWC for .tflite, NCHW for ONNX I/O).

    ``scale`` / ``zero_point``: float32 / int64 arrays, one entry per tensor or one per channel
    along ``axis``; empty when the tensor is not quantized.  ``data``: a constant's values (None
    for activations).
    """

    name: str
    shape: tuple[int, ...]
    dtype: str
    scale: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    zero_point: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    axis: int = 0
    data: np.ndarray | None = field(default=None, repr=False)

    @property
    def quantized(self) -> bool:
        return self.scale.size > 0

    @property
    def constant(self) -> bool:
        return self.data is not None

    def qparams(self) -> tuple[np.float32, int]:
        """``(scale, zero_point)`` of a per-tensor quantized tensor, the scale a float32 value."""
        if self.scale.size != 1:
            raise ValueError(f"tensor {self.name} is not quantized per tensor")
        return np.float32(self.scale[0]), int(self.zero_point[0])

    def plain_qparams(self) -> tuple[float, int]:
        """:meth:`qparams` as Python numbers, for JSON (the same float32 value, held in a float)."""
        scale, zero_point = self.qparams()
        return float(scale), zero_point


@dataclass
class NpuModel:
    inputs: list[str]
    outputs: list[str]
    tensors: dict[str, NpuTensor]

    def activations(self) -> list[NpuTensor]:
        """Quantized, non-constant tensors, in file order."""
        return [t for t in self.tensors.values() if not t.constant and t.quantized]


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


def text(name) -> str:
    """A flatbuffer string (bytes or str) as str."""
    return name.decode() if isinstance(name, bytes) else str(name)


def tflite_tensors(model, raw: bytes, source: str) -> list[NpuTensor]:
    """Every tensor of the first subgraph of ``model`` (from :func:`parse_tflite` on ``raw``), in file order."""
    types = _tflite_type_names()
    return [_tflite_tensor(model, raw, source, t, types) for t in model.subgraphs[0].tensors or []]


def _tflite_tensor(model, raw: bytes, source: str, t, types: dict[int, str]) -> NpuTensor:
    name = text(t.name)
    dtype = types.get(t.type, f"type{t.type}")
    shape = tuple(int(d) for d in (t.shape if t.shape is not None else []))
    q = t.quantization
    scale = np.asarray(q.scale if q is not None and q.scale is not None else [], dtype=np.float32).reshape(-1)
    zps = np.asarray(q.zeroPoint if q is not None and q.zeroPoint is not None else [], dtype=np.int64).reshape(-1)
    if scale.size and zps.size not in (1, scale.size):
        raise UserError(f"{source}: tensor '{name}' has {scale.size} scales but {zps.size} zero points")
    if scale.size and zps.size == 0:
        zps = np.zeros(1, np.int64)
    axis = int(q.quantizedDimension) if q is not None else 0
    return NpuTensor(name, shape, dtype, scale, zps, axis, _constant(model, raw, source, t.buffer, name, shape, dtype))


def _constant(model, raw: bytes, source: str, index: int, name: str, shape: tuple[int, ...], dtype: str) -> np.ndarray | None:
    """The values a tensor's buffer holds; None for an activation (empty buffer)."""
    buffers = model.buffers or []
    if index >= len(buffers):
        return None
    b = buffers[index]
    if b.data is not None and len(b.data):
        data = np.asarray(b.data, dtype=np.uint8).tobytes()
    elif b.offset and b.offset > 1:  # large models keep buffers after the flatbuffer
        if b.offset + b.size > len(raw):
            raise UserError(f"{source}: buffer {index} runs past the end of the file (truncated?)")
        data = raw[b.offset:b.offset + b.size]
    else:
        return None
    try:
        np_type = np.dtype(dtype)
    except TypeError:
        raise UserError(f"{source}: constant tensor '{name}' has element type {dtype}, which mnss-kit does not read") from None
    expected = int(np.prod(shape, dtype=np.int64)) * np_type.itemsize
    if len(data) != expected:
        raise UserError(f"{source}: constant tensor '{name}' holds {len(data)} bytes, shape {list(shape)} of {np_type.name} needs {expected}")
    return np.frombuffer(data, dtype=np_type.newbyteorder("<")).astype(np_type).reshape(shape)


def read_tflite(data: bytes, source: str = "npu.tflite") -> NpuModel:
    """Tensors, inputs and outputs of the first subgraph of a ``.tflite`` flatbuffer."""
    model = parse_tflite(data, source)
    graph = model.subgraphs[0]
    tensors = tflite_tensors(model, data, source)
    inputs = [tensors[i].name for i in graph.inputs]
    outputs = [tensors[i].name for i in graph.outputs]
    return NpuModel(inputs, outputs, {t.name: t for t in tensors})


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
            shape=tuple(int(d.dim_value) for d in tt.shape.dim),
            dtype=_ONNX_TYPES.get(tt.elem_type, f"type{tt.elem_type}"),
        )
    for node in graph.node:
        if node.op_type not in ("QuantizeLinear", "DequantizeLinear") or len(node.input) < 3:
            continue
        integer = node.output[0] if node.op_type == "QuantizeLinear" else node.input[0]
        scale, zp = inits.get(node.input[1]), inits.get(node.input[2])
        if scale is None or zp is None:
            continue
        entry = tensors.setdefault(integer, NpuTensor(integer, (), str(zp.dtype)))
        entry.dtype = str(zp.dtype)
        entry.scale = np.atleast_1d(scale).astype(np.float32).reshape(-1)
        entry.zero_point = np.atleast_1d(zp).astype(np.int64).reshape(-1)
        if entry.scale.size > 1:
            entry.axis = next((a.i for a in node.attribute if a.name == "axis"), 1)
        if integer in inits:
            entry.data = inits[integer]
            entry.shape = tuple(inits[integer].shape)
    return NpuModel([v.name for v in graph.input], [v.name for v in graph.output], tensors)


def nchw_to_nhwc(shape: tuple[int, ...]) -> tuple[int, ...]:
    n, c, h, w = shape
    return n, h, w, c
