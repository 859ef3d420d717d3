"""The quantized graph: the single source of truth for every scale and zero point.

A :class:`Graph` is a list of :class:`Op` over named :class:`Tensor` s, in
execution order, in the NPU's layout: activations are NHWC, convolution
weights OHWI, depthwise weights 1HWC, biases (C,).  It is built from a float
PyTorch module by :mod:`.trace` (float, no parameters yet), given scales and
zero points by :mod:`.params`, and written out by :mod:`.tflite_writer` and
:mod:`.onnx_writer`, which only copy what is here.

Channel order inside the graph can differ from PyTorch's (PixelShuffle's
``c * r^2 + k`` versus DEPTH_TO_SPACE's ``k * C + c``): ``Tensor.channel_order``
records, for every graph channel, the PyTorch channel it holds, so values can
be compared with the float module.  Graph inputs and outputs are always in
PyTorch order.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

OP_KINDS = (
    "CONV_2D",
    "DEPTHWISE_CONV_2D",
    "ADD",
    "MUL",
    "CONCATENATION",
    "LOGISTIC",
    "TANH",
    "AVERAGE_POOL_2D",
    "RESIZE_BILINEAR",
    "DEPTH_TO_SPACE",
    "SPACE_TO_DEPTH",
    "QUANTIZE",
    "DEQUANTIZE",
    "PAD",
)

# Ops whose output must carry its input's scale and zero point (TFLite int8 spec).
KEEPS_INPUT_PARAMS = ("DEPTH_TO_SPACE", "SPACE_TO_DEPTH", "AVERAGE_POOL_2D", "RESIZE_BILINEAR", "PAD")
# Fixed output parameters (scale, zero point) for int8.
FIXED_OUTPUT_PARAMS = {"LOGISTIC": (1.0 / 256.0, -128), "TANH": (1.0 / 128.0, 0)}
# Ops with a fused activation (clamp bounds in the output integer domain).
FUSED_ACTIVATION_OPS = ("CONV_2D", "DEPTHWISE_CONV_2D", "ADD", "MUL")
ACTIVATIONS = ("none", "relu", "relu6", "relu_n1_to_1")


@dataclasses.dataclass
class Tensor:
    """One tensor.  ``shape`` is NHWC for activations.

    ``dtype``: ``float32`` until quantized, then ``int8`` / ``int16`` (activations,
    weights) or ``int32`` (bias).  ``scale``: float per tensor, or a (C,) float32
    array for per-channel weights and biases (``axis`` names that dimension).
    ``data``: the stored values of a constant (quantized ints once quantized);
    ``float_data``: the float values a constant came from.  ``rmin``/``rmax``:
    the calibrated real range (activations).
    """

    name: str
    shape: tuple[int, ...]
    dtype: str = "float32"
    scale: Any = None
    zero_point: Any = 0
    axis: int = 0
    data: np.ndarray | None = None
    float_data: np.ndarray | None = None
    rmin: float | None = None
    rmax: float | None = None
    channel_order: np.ndarray | None = None

    @property
    def is_constant(self) -> bool:
        return self.float_data is not None or self.data is not None

    @property
    def is_quantized(self) -> bool:
        return self.dtype in ("int8", "int16", "int32")

    @property
    def per_channel(self) -> bool:
        return np.ndim(self.scale) == 1

    def params(self) -> tuple[float, int]:
        """``(scale, zero_point)`` of a per-tensor quantized tensor."""
        if self.scale is None or self.per_channel:
            raise ValueError(f"tensor {self.name} has no per-tensor quantization")
        return float(self.scale), int(self.zero_point)


@dataclasses.dataclass
class Op:
    """One operator.  ``options`` hold attributes (stride, padding, activation, ...);
    ``source`` names the PyTorch node it came from, for messages and reports."""

    kind: str
    inputs: list[str]
    outputs: list[str]
    options: dict = dataclasses.field(default_factory=dict)
    source: str = ""

    def __post_init__(self):
        if self.kind not in OP_KINDS:
            raise ValueError(f"unknown op kind {self.kind}")


@dataclasses.dataclass
class Graph:
    tensors: dict[str, Tensor]
    ops: list[Op]
    inputs: list[str]
    outputs: list[str]

    def tensor(self, name: str) -> Tensor:
        return self.tensors[name]

    def producer(self, name: str) -> Op | None:
        for op in self.ops:
            if name in op.outputs:
                return op
        return None

    def consumers(self, name: str) -> list[Op]:
        return [op for op in self.ops if name in op.inputs]

    def activations(self) -> list[str]:
        """Names of the non-constant tensors, graph inputs first, in execution order."""
        names = list(self.inputs)
        for op in self.ops:
            names.extend(n for n in op.outputs if n not in names)
        return names

    def constants(self) -> list[str]:
        return [n for n, t in self.tensors.items() if t.is_constant]

    @property
    def is_quantized(self) -> bool:
        return all(self.tensors[n].is_quantized for n in self.activations())

    def validate(self) -> None:
        """Check structure and, once quantized, the TFLite int8 constraints.  Raises ``ValueError``."""
        known = set(self.inputs) | set(self.constants())
        for op in self.ops:
            missing = [n for n in op.inputs if n not in known]
            if missing:
                raise ValueError(f"{op.kind} ({op.source}) reads {missing[0]} before it is produced")
            known.update(op.outputs)
        for name in self.outputs:
            if name not in known:
                raise ValueError(f"graph output {name} is never produced")
        if self.is_quantized:
            for op in self.ops:
                _check_op_params(self, op)

    def summary_rows(self) -> list[dict]:
        """One row per op: kind, output name, shape, dtype, scale, zero point, source."""
        rows = []
        for op in self.ops:
            t = self.tensors[op.outputs[0]]
            rows.append(
                {
                    "op": op.kind,
                    "output": t.name,
                    "shape": list(t.shape),
                    "dtype": t.dtype,
                    "scale": None if t.scale is None else float(t.scale),
                    "zero_point": int(t.zero_point) if t.scale is not None else None,
                    "source": op.source,
                }
            )
        return rows


def same_padding(size: int, kernel: int, stride: int, dilation: int = 1) -> tuple[int, int]:
    """TFLite SAME padding ``(before, after)`` along one axis: output ``ceil(size / stride)``, the odd pixel after."""
    out = -(-size // stride)
    total = max((out - 1) * stride + (kernel - 1) * dilation + 1 - size, 0)
    return total // 2, total - total // 2


def conv_pads(graph: Graph, op: Op) -> tuple[int, int, int, int]:
    """Explicit ``(top, bottom, left, right)`` padding of a CONV_2D / DEPTHWISE_CONV_2D / AVERAGE_POOL_2D."""
    if op.options["padding"] == "VALID":
        return (0, 0, 0, 0)
    _, h, w, _ = graph.tensors[op.inputs[0]].shape
    if op.kind == "AVERAGE_POOL_2D":
        kh, kw = op.options["kernel"]
    else:
        _, kh, kw, _ = graph.tensors[op.inputs[1]].shape
    (sh, sw), (dh, dw) = op.options["stride"], op.options.get("dilation", (1, 1))
    return same_padding(h, kh, sh, dh) + same_padding(w, kw, sw, dw)


def _check_op_params(graph: Graph, op: Op) -> None:
    out = graph.tensors[op.outputs[0]]
    ins = [graph.tensors[n] for n in op.inputs]
    where = f"{op.kind} ({op.source})"
    if op.kind in KEEPS_INPUT_PARAMS and ins[0].params() != out.params():
        raise ValueError(f"{where}: output params {out.params()} differ from input params {ins[0].params()}")
    if op.kind == "CONCATENATION":
        for t in ins:
            if t.params() != out.params():
                raise ValueError(f"{where}: input {t.name} params {t.params()} differ from output {out.params()}")
    if op.kind in FIXED_OUTPUT_PARAMS and out.dtype == "int8":
        scale, zp = FIXED_OUTPUT_PARAMS[op.kind]
        if not (np.float32(out.scale) == np.float32(scale) and out.zero_point == zp):
            raise ValueError(f"{where}: output params must be ({scale}, {zp})")
    if op.kind in ("CONV_2D", "DEPTHWISE_CONV_2D"):
        x, w, b = ins
        if w.dtype != "int8" or b.dtype not in ("int32", "int64"):
            raise ValueError(f"{where}: weights must be int8 and bias int32")
        if np.any(np.abs(w.data.astype(np.int32)) > 127) or np.any(np.asarray(w.zero_point) != 0):
            raise ValueError(f"{where}: weights must be symmetric in [-127, 127]")
        expected = (np.float32(x.scale) * np.asarray(w.scale, np.float32)).astype(np.float32)
        if not np.array_equal(np.asarray(b.scale, np.float32), expected) or np.any(np.asarray(b.zero_point) != 0):
            raise ValueError(f"{where}: bias scale must be input scale x weight scale, zero point 0")


def prefix_graph(graph: Graph, name: str) -> Graph:
    """The ops up to the one producing ``name``, with ``name`` as the only output.

    Runs a tensor through the whole graph above it in runtimes that keep no intermediate
    values (a delegate such as XNNPACK writes only its outputs).
    """
    ops = []
    for op in graph.ops:
        ops.append(op)
        if name in op.outputs:
            break
    else:
        raise ValueError(f"no op produces {name!r}")
    used = {n for op in ops for n in op.inputs + op.outputs}
    tensors = {n: t for n, t in graph.tensors.items() if n in used}
    return Graph(tensors, ops, [n for n in graph.inputs if n in used], [name])


def op_graph(graph: Graph, op: Op) -> Graph:
    """A graph holding only ``op``: its activation inputs become graph inputs (for per-op checks)."""
    names = list(dict.fromkeys(op.inputs + op.outputs))
    inputs = [n for n in dict.fromkeys(op.inputs) if not graph.tensors[n].is_constant]
    tensors = {n: graph.tensors[n] for n in names}
    return Graph(tensors, [op], inputs, list(op.outputs))
