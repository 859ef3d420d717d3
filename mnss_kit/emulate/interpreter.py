"""Op-by-op numpy interpretation of an :class:`~.npu_graph.NpuGraph` under one runtime.

Each operator is prepared once (:meth:`NumpyInterpreter._prepare`: parameters
read from the graph, requantization multipliers computed, unsupported
combinations refused with a ``UserError`` naming the operator) and then run
per frame.  The arithmetic is ``emulate.kernels`` (convolutions through the
bit-identical fast requantization of ``emulate.fast``); the runtime is data
(``ops.runtimes``) and the interpreter never branches on its name.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import UserError
from ..export.npu_files import NpuTensor
from ..ops.int8.logistic_tanh import LOGISTIC_OUTPUT, TANH_OUTPUT
from ..ops.runtimes import Runtime
from . import fast, kernels
from .npu_graph import NpuGraph, NpuOp

Step = Callable[[list[np.ndarray]], np.ndarray]


class NumpyInterpreter:
    """Runs ``graph`` with the kernels of ``runtime``; int8 NHWC tensors in and out."""

    def __init__(self, graph: NpuGraph, runtime: Runtime):
        self.graph = graph
        self.rt = runtime
        for name in graph.execution_order():
            t = graph.tensors[name]
            if t.dtype not in ("int8", "float32"):
                raise UserError(f"{graph.source}: tensor '{name}' is {t.dtype}; the numpy kernels cover int8 "
                                f"activations only (run 16-bit graphs with --npu-backend litert)")
        # (op, the input names its step reads (constants arrive as their data), the prepared step)
        self.steps: list[tuple[NpuOp, list[str], Step]] = [(op, [n for n in op.inputs if n], self._prepare(op)) for op in graph.ops]

    # -- running ------------------------------------------------------------------------------
    def run(self, inputs: dict[str, np.ndarray], keep_all: bool = False) -> dict[str, np.ndarray]:
        """Graph inputs by name -> outputs by name (every activation with ``keep_all``)."""
        values = {n: inputs[n] for n in self.graph.inputs}
        last_use = self._last_use()
        for i, (op, names, step) in enumerate(self.steps):
            result = step([values[n] if n in values else self.graph.tensors[n].data for n in names])
            out = self.graph.tensors[op.outputs[0]]
            if tuple(result.shape) != out.shape:
                raise UserError(f"{self.graph.source}: {op.describe()} computes shape {list(result.shape)}, "
                                f"the file declares {list(out.shape)} for '{out.name}'")
            values[out.name] = result
            if not keep_all:
                for n in last_use.get(i, ()):
                    values.pop(n, None)
        if keep_all:
            return values
        return {n: values[n] for n in self.graph.outputs}

    def _last_use(self) -> dict[int, list[str]]:
        """Operator index -> activations no later operator reads (freed after it, outputs kept)."""
        last: dict[str, int] = {}
        for i, (op, names, _) in enumerate(self.steps):
            for n in names:
                last[n] = i
        freed: dict[int, list[str]] = {}
        for n, i in last.items():
            if n not in self.graph.outputs:
                freed.setdefault(i, []).append(n)
        return freed

    # -- preparation --------------------------------------------------------------------------
    def fail(self, op: NpuOp, message: str) -> UserError:
        return UserError(f"{self.graph.source}: {op.describe()}: {message}")

    def tensor(self, name: str) -> NpuTensor:
        return self.graph.tensors[name]

    def qparams(self, op: NpuOp, name: str) -> tuple[float, int]:
        t = self.tensor(name)
        if not t.quantized or t.scale.size != 1:
            raise self.fail(op, f"tensor '{name}' needs one scale and zero point (per-tensor int8)")
        return t.qparams()

    def _prepare(self, op: NpuOp) -> Step:
        prepare = getattr(self, "_prepare_" + op.kind.lower())
        return prepare(op)

    def _prepare_conv_2d(self, op: NpuOp) -> Step:
        x_q, out_q = self.qparams(op, op.inputs[0]), self.qparams(op, op.outputs[0])
        w = self.tensor(op.inputs[1])
        bias = self._bias(op, w.shape[0])
        cin = self.tensor(op.inputs[0]).shape[-1]
        if len(w.shape) != 4 or w.shape[3] != cin:
            raise self.fail(op, f"weights '{w.name}' have shape {list(w.shape)}, expected (Co, KH, KW, {cin})")
        requantize = fast.Requantizer(x_q, self._weight_scales(op, w, w.shape[0]), out_q, op.options["activation"], self.rt)
        weights, stride, padding = w.data, op.options["stride"], op.options["padding"]
        return lambda v: fast.conv2d(v[0], x_q, weights, bias, requantize, stride, padding)

    def _prepare_depthwise_conv_2d(self, op: NpuOp) -> Step:
        x_q, out_q = self.qparams(op, op.inputs[0]), self.qparams(op, op.outputs[0])
        w = self.tensor(op.inputs[1])
        cin = self.tensor(op.inputs[0]).shape[-1]
        if len(w.shape) != 4 or w.shape[0] != 1 or w.shape[3] % cin:
            raise self.fail(op, f"weights '{w.name}' have shape {list(w.shape)}, expected (1, KH, KW, a multiple of {cin})")
        channels = w.shape[3]
        bias = self._bias(op, channels)
        requantizers = fast.DepthwiseRequantizers(x_q, self._weight_scales(op, w, channels), out_q,
                                                  op.options["activation"], channels, self.rt)
        weights, stride, padding = w.data, op.options["stride"], op.options["padding"]
        return lambda v: fast.depthwise_conv2d(v[0], x_q, weights, bias, requantizers, stride, padding)

    def _weight_scales(self, op: NpuOp, w: NpuTensor, channels: int) -> np.ndarray:
        if w.dtype != "int8" or not w.quantized:
            raise self.fail(op, f"weights '{w.name}' must be quantized int8")
        if np.any(w.zero_point != 0):
            raise self.fail(op, f"weights '{w.name}' have a nonzero zero point (int8 weights are symmetric)")
        if w.scale.size not in (1, channels):
            raise self.fail(op, f"weights '{w.name}' have {w.scale.size} scales for {channels} output channels")
        return np.broadcast_to(w.scale, (channels,)).astype(np.float32)

    def _bias(self, op: NpuOp, channels: int) -> np.ndarray | None:
        if len(op.inputs) < 3 or not op.inputs[2]:
            return None
        b = self.tensor(op.inputs[2])
        if b.data is None or b.dtype != "int32" or b.shape != (channels,):
            raise self.fail(op, f"bias '{b.name}' must be a constant int32 ({channels},), got {b.dtype} {list(b.shape)}")
        return b.data

    def _binary(self, op: NpuOp, kernel) -> Step:
        a, b = (self.tensor(n) for n in op.inputs[:2])
        if a.shape != b.shape:
            raise self.fail(op, f"operands '{a.name}' {list(a.shape)} and '{b.name}' {list(b.shape)} differ in shape; "
                                "broadcasting is not implemented by the emulator")
        a_q, b_q, out_q = (self.qparams(op, n) for n in (op.inputs[0], op.inputs[1], op.outputs[0]))
        activation, rt = op.options["activation"], self.rt
        if a.dtype == b.dtype == "int8" and fast.pair_table_is_exact(op.kind, rt, int(np.prod(a.shape))):
            table = fast.PairTable(kernel, a_q, b_q, out_q, activation, rt)
            return lambda v: table(np.ascontiguousarray(v[0]), np.ascontiguousarray(v[1]))
        return lambda v: kernel(v[0], a_q, v[1], b_q, out_q, activation, rt)

    def _prepare_add(self, op: NpuOp) -> Step:
        return self._binary(op, kernels.add)

    def _prepare_mul(self, op: NpuOp) -> Step:
        return self._binary(op, kernels.mul)

    def _prepare_concatenation(self, op: NpuOp) -> Step:
        out_q = self.qparams(op, op.outputs[0])
        for n in op.inputs:
            if self.qparams(op, n) != out_q:
                raise self.fail(op, f"input '{n}' has params {self.qparams(op, n)}, the output {out_q}; "
                                    "the int8 spec requires one scale and zero point")
        if op.options["activation"] != "none":
            raise self.fail(op, "a fused activation on CONCATENATION is not implemented by the emulator")
        axis = op.options["axis"]
        return lambda v: kernels.concatenation(v, axis=axis)

    def _table(self, op: NpuOp, kernel, fixed: tuple[float, int]) -> Step:
        x_q, out_q = self.qparams(op, op.inputs[0]), self.qparams(op, op.outputs[0])
        if np.float32(out_q[0]) != np.float32(fixed[0]) or out_q[1] != fixed[1]:
            raise self.fail(op, f"output params {out_q} must be {fixed} for int8")
        rt = self.rt
        return lambda v: kernel(v[0], x_q, rt)

    def _prepare_logistic(self, op: NpuOp) -> Step:
        return self._table(op, kernels.logistic, LOGISTIC_OUTPUT)

    def _prepare_tanh(self, op: NpuOp) -> Step:
        return self._table(op, kernels.tanh, TANH_OUTPUT)

    def _same_params(self, op: NpuOp) -> tuple[float, int]:
        x_q, out_q = self.qparams(op, op.inputs[0]), self.qparams(op, op.outputs[0])
        if x_q != out_q:
            raise self.fail(op, f"output params {out_q} differ from input params {x_q}; the int8 spec keeps them")
        return out_q

    def _prepare_average_pool_2d(self, op: NpuOp) -> Step:
        out_q = self._same_params(op)
        o, rt = op.options, self.rt
        return lambda v: kernels.average_pool2d(v[0], o["size"], o["stride"], o["padding"], o["activation"], out_q, rt)

    def _prepare_resize_bilinear(self, op: NpuOp) -> Step:
        self._same_params(op)
        size, half, rt = op.options["size"], op.options["half_pixel_centers"], self.rt
        return lambda v: kernels.resize_bilinear(v[0], size, half, rt)

    def _prepare_depth_to_space(self, op: NpuOp) -> Step:
        self._same_params(op)
        block = op.options["block"]
        return lambda v: kernels.depth_to_space(v[0], block)

    def _prepare_space_to_depth(self, op: NpuOp) -> Step:
        self._same_params(op)
        block = op.options["block"]
        return lambda v: kernels.space_to_depth(v[0], block)

    def _prepare_pad(self, op: NpuOp) -> Step:
        _, zero_point = self._same_params(op)
        paddings = op.options["paddings"]
        if paddings.shape != (4, 2):
            raise self.fail(op, f"paddings have shape {list(paddings.shape)}, expected [4, 2]")
        return lambda v: kernels.pad(v[0], paddings, zero_point)

    def _prepare_quantize(self, op: NpuOp) -> Step:
        out_q, rt = self.qparams(op, op.outputs[0]), self.rt
        if self.tensor(op.inputs[0]).dtype == "float32":
            return lambda v: kernels.quantize(np.asarray(v[0], np.float32), out_q, rt)
        x_q = self.qparams(op, op.inputs[0])
        return lambda v: kernels.requantize(v[0], x_q, out_q, rt)

    def _prepare_dequantize(self, op: NpuOp) -> Step:
        x_q, rt = self.qparams(op, op.inputs[0]), self.rt
        return lambda v: kernels.dequantize(v[0], x_q, rt)
