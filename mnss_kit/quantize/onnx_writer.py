"""Graph -> ONNX: the float model (for calibration) and ``npu_qdq.onnx``.

Layout: **NCHW** (ONNX Conv is channels-first).  Inputs and outputs are NCHW in
PyTorch channel order; inside, a tensor keeps the graph's channel order.
Quantized tensors are written QDQ style: the float op's result goes through
``QuantizeLinear`` into an integer tensor carrying the graph's name, and a
``DequantizeLinear`` feeds the consumers; weights and biases are integer
initializers behind ``DequantizeLinear`` (per channel on axis 0).  Scales and
zero points are copied from the graph, nothing is re-derived.  ONNX Runtime
fuses these groups into QLinear kernels.
"""

from __future__ import annotations

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from .graph import Graph, Op, conv_pads

OPSET = 21  # int16 QuantizeLinear / DequantizeLinear
ONNX_DTYPES = {"float32": TensorProto.FLOAT, "int8": TensorProto.INT8, "int16": TensorProto.INT16, "int32": TensorProto.INT32}


def nchw(shape) -> list[int]:
    n, h, w, c = shape
    return [n, c, h, w]


def to_onnx(
    graph: Graph,
    quantize: bool = True,
    only: set[str] | None = None,
    expose: list[str] | None = None,
) -> onnx.ModelProto:
    """Write ``graph`` as ONNX.

    ``quantize``: QDQ model (needs a quantized graph); otherwise the float model.
    ``only``: quantize just these activation tensors (with their producers'
    weights); the rest stays float and I/O is float (used for sensitivity).
    ``expose``: extra activation tensors to add as graph outputs (integer ones
    in a QDQ model, float ones otherwise), named as in the graph.
    """
    return _Writer(graph, quantize, only).build(expose or [])


class _Writer:
    def __init__(self, graph: Graph, quantize: bool, only: set[str] | None):
        self.g = graph
        self.partial = only is not None
        self.quantized = set(graph.activations()) if quantize and only is None else set(only or [])
        self.nodes: list[onnx.NodeProto] = []
        self.inits: list[onnx.TensorProto] = []
        self.init_names: set[str] = set()
        self.float_name: dict[str, str] = {}  # graph activation -> name of its float value

    # -- building blocks ----------------------------------------------
    def init(self, name: str, array: np.ndarray) -> str:
        if name not in self.init_names:  # a tensor's scale and zero point are shared by its Q and DQ
            self.init_names.add(name)
            self.inits.append(numpy_helper.from_array(np.asarray(array), name))
        return name

    def node(self, op_type: str, inputs: list[str], outputs: list[str], **attrs) -> None:
        self.nodes.append(helper.make_node(op_type, inputs, outputs, name=f"{outputs[0]}.{op_type}", **attrs))

    def qparams(self, name: str) -> tuple[str, str]:
        t = self.g.tensors[name]
        scale = self.init(f"{name}.scale", np.asarray(t.scale, dtype=np.float32))
        zp = self.init(f"{name}.zero_point", np.asarray(t.zero_point, dtype=t.dtype))
        return scale, zp

    def dequantize(self, name: str) -> str:
        """Float value of activation ``name`` (the integer tensor goes through DequantizeLinear)."""
        scale, zp = self.qparams(name)
        out = f"{name}.dq"
        self.node("DequantizeLinear", [name, scale, zp], [out])
        return out

    def produce(self, name: str) -> str:
        """Name the float op should write for activation ``name`` (see :meth:`finish`)."""
        return f"{name}.float" if name in self.quantized else name

    def finish(self, name: str) -> None:
        """After the op producing ``name``: its QuantizeLinear and DequantizeLinear, if quantized."""
        if name not in self.quantized:
            self.float_name[name] = name
            return
        scale, zp = self.qparams(name)
        self.node("QuantizeLinear", [f"{name}.float", scale, zp], [name])
        self.float_name[name] = self.dequantize(name)

    def read(self, name: str) -> str:
        return self.float_name[name]

    def weight(self, op: Op) -> tuple[str, str]:
        """Float weight (OIHW) and bias names of a convolution; DequantizeLinear'd when quantized."""
        w, b = (self.g.tensors[n] for n in op.inputs[1:])
        quantized = op.outputs[0] in self.quantized and w.dtype == "int8"
        if op.kind == "CONV_2D":
            perm = (0, 3, 1, 2)  # OHWI -> OIHW
        else:
            perm = (3, 0, 1, 2)  # 1HWC -> C1HW
        if not quantized:
            return self.init(w.name, np.transpose(w.float_data, perm)), self.init(b.name, b.float_data)
        wq = self.init(w.name, np.transpose(w.data, perm))
        ws = self.init(f"{w.name}.scale", np.asarray(w.scale, np.float32))
        wz = self.init(f"{w.name}.zero_point", np.zeros(len(w.scale), np.int8))
        self.node("DequantizeLinear", [wq, ws, wz], [f"{w.name}.dq"], axis=0)
        bq = self.init(b.name, b.data)
        bs = self.init(f"{b.name}.scale", np.asarray(b.scale, np.float32))
        bz = self.init(f"{b.name}.zero_point", np.zeros(len(b.scale), np.int32))
        self.node("DequantizeLinear", [bq, bs, bz], [f"{b.name}.dq"], axis=0)
        return f"{w.name}.dq", f"{b.name}.dq"

    def constant(self, name: str) -> str:
        t = self.g.tensors[name]
        return self.init(name, t.float_data.transpose(0, 3, 1, 2))

    def activation(self, op: Op, value: str, out: str) -> None:
        lo, hi = op.options.get("clamp", (None, None))
        if op.options.get("activation", "none") == "none":
            self.node("Identity", [value], [out])
        elif op.options["activation"] == "relu":
            self.node("Relu", [value], [out])
        else:
            bounds = [self.init(f"{out}.min", np.float32(-np.inf if lo is None else lo)), self.init(f"{out}.max", np.float32(np.inf if hi is None else hi))]
            self.node("Clip", [value] + bounds, [out])

    # -- ops ---------------------------------------------------------------
    def op(self, op: Op) -> None:
        out = self.produce(op.outputs[0])
        x = [self.read(n) if n in self.float_name else self.constant(n) for n in op.inputs[:1]]
        k = op.kind
        if k in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            w, b = self.weight(op)
            t, bo, l, r = conv_pads(self.g, op)
            group = self.g.tensors[op.inputs[0]].shape[3] if k == "DEPTHWISE_CONV_2D" else 1
            raw = f"{op.outputs[0]}.conv"
            self.node("Conv", [x[0], w, b], [raw], strides=list(op.options["stride"]), dilations=list(op.options["dilation"]), pads=[t, l, bo, r], group=group)
            self.activation(op, raw, out)
        elif k in ("ADD", "MUL"):
            b = op.inputs[1]
            other = self.read(b) if b in self.float_name else self.scalar(b, op)
            raw = f"{op.outputs[0]}.raw"
            self.node("Add" if k == "ADD" else "Mul", [x[0], other], [raw])
            self.activation(op, raw, out)
        elif k == "CONCATENATION":
            self.node("Concat", [self.read(n) for n in op.inputs], [out], axis=1)
        elif k == "LOGISTIC":
            self.node("Sigmoid", x, [out])
        elif k == "TANH":
            self.node("Tanh", x, [out])
        elif k == "AVERAGE_POOL_2D":
            t, bo, l, r = conv_pads(self.g, op)
            self.node("AveragePool", x, [out], kernel_shape=list(op.options["kernel"]), strides=list(op.options["stride"]), pads=[t, l, bo, r], count_include_pad=0)
        elif k == "RESIZE_BILINEAR":
            n, _, _, c = self.g.tensors[op.outputs[0]].shape
            sizes = self.init(f"{op.outputs[0]}.sizes", np.array([n, c, *op.options["size"]], np.int64))
            mode = "align_corners" if op.options["align_corners"] else "half_pixel"
            self.node("Resize", [x[0], "", "", sizes], [out], mode="linear", coordinate_transformation_mode=mode)
        elif k == "DEPTH_TO_SPACE":
            self.node("DepthToSpace", x, [out], blocksize=op.options["block_size"], mode="DCR")
        elif k == "SPACE_TO_DEPTH":
            self.node("SpaceToDepth", x, [out], blocksize=op.options["block_size"])
        elif k == "PAD":
            t, bo, l, r = op.options["pads"]
            pads = self.init(f"{op.outputs[0]}.pads", np.array([0, 0, t, l, 0, 0, bo, r], np.int64))
            self.node("Pad", [x[0], pads], [out], mode="constant")
        elif k in ("QUANTIZE", "DEQUANTIZE"):
            self.node("Identity", x, [out])  # a change of integer type is a DQ -> Q pair in QDQ form
        else:
            raise ValueError(f"no ONNX form for {k}")

    def scalar(self, name: str, op: Op) -> str:
        t = self.g.tensors[name]
        if op.outputs[0] in self.quantized and t.dtype in ("int8", "int16"):
            q = self.init(name, t.data.reshape(()))
            s = self.init(f"{name}.scale", np.asarray(t.scale, np.float32))
            z = self.init(f"{name}.zero_point", np.asarray(t.zero_point, t.dtype))
            self.node("DequantizeLinear", [q, s, z], [f"{name}.dq"])
            return f"{name}.dq"
        return self.init(name, t.float_data.reshape(()))

    # -- model ---------------------------------------------------------------
    def build(self, expose: list[str]) -> onnx.ModelProto:
        io_int = bool(self.quantized) and not self.partial
        inputs = []
        for name in self.g.inputs:
            t = self.g.tensors[name]
            if io_int:
                inputs.append(helper.make_tensor_value_info(name, ONNX_DTYPES[t.dtype], nchw(t.shape)))
                self.float_name[name] = self.dequantize(name)
            elif name in self.quantized:  # float input, quantized then dequantized inside
                inputs.append(helper.make_tensor_value_info(f"{name}.input", TensorProto.FLOAT, nchw(t.shape)))
                scale, zp = self.qparams(name)
                self.node("QuantizeLinear", [f"{name}.input", scale, zp], [name])
                self.float_name[name] = self.dequantize(name)
            else:
                inputs.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, nchw(t.shape)))
                self.float_name[name] = name
        for op in self.g.ops:
            self.op(op)
            self.finish(op.outputs[0])
        outputs, seen = [], set()
        for name in list(self.g.outputs) + [n for n in expose if n not in self.g.outputs]:
            t = self.g.tensors[name]
            if name in seen:
                continue
            seen.add(name)
            if io_int or (name in self.quantized and name in expose and name not in self.g.outputs):
                outputs.append(helper.make_tensor_value_info(name, ONNX_DTYPES[t.dtype], nchw(t.shape)))
            else:
                value = self.read(name)
                if value != name:
                    self.node("Identity", [value], [f"{name}.out"])
                    value = f"{name}.out"
                outputs.append(helper.make_tensor_value_info(value, TensorProto.FLOAT, nchw(t.shape)))
        graph = helper.make_graph(self.nodes, "npu", inputs, outputs, initializer=self.inits)
        model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name="mnss-kit")
        model.ir_version = 10
        onnx.checker.check_model(model)
        return model
