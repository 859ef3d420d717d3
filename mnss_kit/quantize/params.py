"""Float graph + calibrated ranges -> quantized graph (every scale and zero point decided here).

Activations: per-tensor asymmetric int8 from their calibrated range, or
symmetric int16 for the tensors chosen for 16-bit activations.  Tensors that
the int8 spec ties together (concatenation inputs and output; the input and
output of DEPTH_TO_SPACE, SPACE_TO_DEPTH, PAD, pooling, resizing) form one
group with one range; LOGISTIC and TANH outputs have fixed parameters.
Weights: symmetric int8 per output channel; biases int32 at
``s_in * s_w[c]``, with a channel's weight scale raised if its bias would
overflow.  Where an op's input is stored in another integer type than the op
computes in, a QUANTIZE op converts it.
"""

from __future__ import annotations

import copy

import numpy as np

from ..errors import UserError
from ..ops.int8.quantize import choose_qparams, quantize
from ..ops.int8.ranges import INT32_MAX, qrange
from ..ops.int8.weights import bias_scales, quantize_bias, quantize_weights_per_channel, quantize_weights_with_scales
from .graph import FIXED_OUTPUT_PARAMS, KEEPS_INPUT_PARAMS, Graph, Op, Tensor

INT16_FIXED_OUTPUT = {"LOGISTIC": (1.0 / 32768.0, 0), "TANH": (1.0 / 32768.0, 0)}


def quantize_graph(graph: Graph, ranges: dict[str, tuple[float, float]], int16: set[str] | frozenset = frozenset()) -> Graph:
    """Return a quantized copy of float ``graph``.

    ``ranges``: real ``(min, max)`` of every activation tensor (from calibration).
    ``int16``: activation tensors to store as symmetric int16 (A16W8).
    """
    g = copy.deepcopy(graph)
    missing = [n for n in g.activations() if n not in ranges]
    if missing:
        raise ValueError(f"no calibrated range for {missing[:3]}")
    groups = _param_groups(g)
    for members in groups:
        _assign_group(g, members, ranges, int16)
    _insert_conversions(g)
    for op in g.ops:
        _quantize_constants(g, op)
        _check_clamp(g, op)
    g.validate()
    return g


def _param_groups(g: Graph) -> list[list[str]]:
    parent = {n: n for n in g.activations()}

    def find(n):
        while parent[n] != n:
            parent[n] = parent[parent[n]]
            n = parent[n]
        return n

    def union(a, b):
        parent[find(a)] = find(b)

    for op in g.ops:
        if op.kind in KEEPS_INPUT_PARAMS:
            union(op.inputs[0], op.outputs[0])
        elif op.kind == "CONCATENATION":
            for n in op.inputs:
                union(n, op.outputs[0])
    groups: dict[str, list[str]] = {}
    for n in g.activations():
        groups.setdefault(find(n), []).append(n)
    return list(groups.values())


def _assign_group(g: Graph, members: list[str], ranges, int16) -> None:
    dtype = "int16" if any(n in int16 for n in members) else "int8"
    fixed = {}
    for n in members:
        op = g.producer(n)
        if op is not None and op.kind in FIXED_OUTPUT_PARAMS:
            fixed[n] = (INT16_FIXED_OUTPUT if dtype == "int16" else FIXED_OUTPUT_PARAMS)[op.kind]
    lo = min(float(ranges[n][0]) for n in members)
    hi = max(float(ranges[n][1]) for n in members)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise UserError(f"calibration produced a non-finite range for tensor '{members[0]}' (NaN or Inf in the data?)")
    if len(set(fixed.values())) > 1:
        raise UserError(f"tensors {sorted(fixed)} must share quantization but both have fixed parameters (sigmoid and tanh into one concatenation)")
    if fixed:
        scale, zp = next(iter(fixed.values()))
        scale = np.float32(scale)
    else:
        scale, zp = choose_qparams(lo, hi, dtype, symmetric=dtype == "int16")
    for n in members:
        t = g.tensors[n]
        t.dtype, t.scale, t.zero_point = dtype, np.float32(scale), int(zp)
        t.rmin, t.rmax = float(ranges[n][0]), float(ranges[n][1])


def _insert_conversions(g: Graph) -> None:
    """QUANTIZE ops where an op reads a tensor stored in another integer type than its output."""
    ops: list[Op] = []
    converted: dict[tuple[str, str], str] = {}
    for op in g.ops:
        out_dtype = g.tensors[op.outputs[0]].dtype
        if op.kind not in ("QUANTIZE", "DEQUANTIZE"):
            for i, name in enumerate(op.inputs):
                t = g.tensors[name]
                if t.is_constant or t.dtype == out_dtype:
                    continue
                key = (name, out_dtype)
                if key not in converted:
                    converted[key] = _conversion(g, t, out_dtype, op, ops)
                op.inputs[i] = converted[key]
        ops.append(op)
    g.ops = ops


def _conversion(g: Graph, t: Tensor, dtype: str, consumer: Op, ops: list[Op]) -> str:
    name = f"{t.name}.{dtype}"
    scale, zp = choose_qparams(t.rmin, t.rmax, dtype, symmetric=dtype == "int16")
    g.tensors[name] = Tensor(name=name, shape=t.shape, dtype=dtype, scale=np.float32(scale), zero_point=int(zp), rmin=t.rmin, rmax=t.rmax, channel_order=t.channel_order)
    ops.append(Op("QUANTIZE", [t.name], [name], {}, source=consumer.source))
    return name


def _quantize_constants(g: Graph, op: Op) -> None:
    if op.kind in ("CONV_2D", "DEPTHWISE_CONV_2D"):
        x, w, b = (g.tensors[n] for n in op.inputs)
        axis = 0 if op.kind == "CONV_2D" else 3
        _, scales = quantize_weights_per_channel(w.float_data, axis)
        scales = _fit_bias(b.float_data, x.scale, scales)
        w.data = quantize_weights_with_scales(w.float_data, scales, axis)
        w.dtype, w.scale, w.zero_point, w.axis = "int8", scales, np.zeros(len(scales), np.int64), axis
        b.data = quantize_bias(b.float_data, x.scale, scales)
        b.dtype, b.scale, b.zero_point, b.axis = "int32", bias_scales(x.scale, scales), np.zeros(len(scales), np.int64), 0
    elif op.kind in ("ADD", "MUL"):
        c = g.tensors[op.inputs[1]]
        if c.is_constant:
            dtype = g.tensors[op.outputs[0]].dtype
            v = float(c.float_data.reshape(-1)[0])
            scale, zp = choose_qparams(min(v, 0.0), max(v, 0.0), dtype, symmetric=dtype == "int16")
            c.data = quantize(c.float_data, scale, zp, dtype)
            c.dtype, c.scale, c.zero_point = dtype, np.float32(scale), int(zp)


def _fit_bias(bias: np.ndarray, input_scale: float, scales: np.ndarray) -> np.ndarray:
    """Raise weight scales whose channel's bias would not fit int32 at ``s_in * s_w``."""
    limit = np.float64(INT32_MAX) * 0.99
    needed = np.abs(bias.astype(np.float64)) / (np.float64(input_scale) * limit)
    return np.maximum(scales, needed.astype(np.float32) * np.float32(1.0001)).astype(np.float32)


def _check_clamp(g: Graph, op: Op) -> None:
    """A general clamp has no TFLite fused form: the output's range must already end inside its bounds."""
    if op.options.get("activation") != "clamp":
        return
    t = g.tensors[op.outputs[0]]
    qmin, qmax = qrange(t.dtype)
    lo_real = float(t.scale) * (qmin - t.zero_point)
    hi_real = float(t.scale) * (qmax - t.zero_point)
    lo, hi = op.options["clamp"]
    tol = float(t.scale)
    if (lo is not None and lo_real < lo - tol) or (hi is not None and hi_real > hi + tol):
        raise UserError(
            f"clamp after '{op.source}' to [{lo}, {hi}] cannot be kept: its output shares quantization with a wider tensor "
            f"(range [{lo_real:.4g}, {hi_real:.4g}]); clamp after the concatenation instead"
        )


def requantize_constants(graph: Graph) -> Graph:
    """Re-quantize weights, biases and scalar constants from their ``float_data`` (activation parameters unchanged)."""
    for op in graph.ops:
        _quantize_constants(graph, op)
    graph.validate()
    return graph


def int16_blocker(graph: Graph, name: str) -> str | None:
    """Why activation ``name`` cannot be stored as int16 in LiteRT, or None if it can.

    DEPTH_TO_SPACE and SPACE_TO_DEPTH have no int16 kernels (their tensors share
    parameters with their neighbours, so the whole group is affected), a general
    clamp relies on int8 saturation, and the graph's inputs and outputs are the
    int8 GPU <-> NPU boundary a bundle's shaders pack and unpack.
    """
    group = next(m for m in _param_groups(graph) if name in m)
    for member in group:
        for op in [graph.producer(member)] + graph.consumers(member):
            if op is None:
                continue
            if op.kind in ("DEPTH_TO_SPACE", "SPACE_TO_DEPTH") and (member in op.outputs or member == op.inputs[0]):
                return f"{op.kind} has no int16 kernel"
            if member in op.outputs and op.options.get("activation") == "clamp":
                return "clamp is enforced by int8 saturation"
    if any(member in graph.inputs or member in graph.outputs for member in group):
        return "a graph input or output: the GPU <-> NPU boundary is int8"
    return None
