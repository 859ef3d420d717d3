"""The graph executed in PyTorch: float, or fake-quantized with the graph's own parameters; short QAT.

:class:`GraphModule` runs a :class:`~.graph.Graph` op by op on NCHW tensors (in
the graph's channel order).  With ``fake_quant`` every activation goes through
``fake_quantize_per_tensor_affine`` at the scale and zero point stored in the
graph and every weight through per-channel fake quantization whose scales are
recomputed from the current weights exactly as :mod:`.params` computes them,
so what training sees is what is exported.  :func:`finetune` trains the
weights to match the float module's outputs (distillation, no labels) and
returns a graph re-quantized with the same activation parameters.
"""

from __future__ import annotations

import copy
from typing import Sequence

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from ..ops.int8.ranges import WEIGHT_MAX, qrange
from .graph import Graph, conv_pads


def depth_to_space_dcr(x: torch.Tensor, r: int) -> torch.Tensor:
    """DEPTH_TO_SPACE on NCHW: input channel ``(dy * r + dx) * C + c`` -> output ``(c, y * r + dy, x * r + dx)``."""
    n, cr2, h, w = x.shape
    c = cr2 // (r * r)
    return x.reshape(n, r, r, c, h, w).permute(0, 3, 4, 1, 5, 2).reshape(n, c, h * r, w * r)


def space_to_depth_dcr(x: torch.Tensor, r: int) -> torch.Tensor:
    """SPACE_TO_DEPTH on NCHW, the inverse of :func:`depth_to_space_dcr`."""
    n, c, h, w = x.shape
    return x.reshape(n, c, h // r, r, w // r, r).permute(0, 3, 5, 1, 2, 4).reshape(n, r * r * c, h // r, w // r)


class GraphModule(nn.Module):
    """``forward(*inputs)``: NCHW float inputs (PyTorch channel order) -> outputs, or all activations.

    Weights are trainable parameters (graph layout: OHWI / 1HWC).
    """

    def __init__(self, graph: Graph, fake_quant: bool = False):
        super().__init__()
        self.graph = graph
        self.fake_quant = fake_quant and graph.is_quantized
        self.weights = nn.ParameterDict()
        for name in graph.constants():
            t = graph.tensors[name]
            self.weights[_key(name)] = nn.Parameter(torch.from_numpy(np.array(t.float_data, np.float32)))

    def const(self, name: str) -> torch.Tensor:
        return self.weights[_key(name)]

    def quant_act(self, name: str, x: torch.Tensor) -> torch.Tensor:
        t = self.graph.tensors[name]
        if not self.fake_quant:
            return x
        qmin, qmax = qrange(t.dtype)
        return torch.fake_quantize_per_tensor_affine(x, float(t.scale), int(t.zero_point), qmin, qmax)

    def quant_weight(self, w: torch.Tensor, axis: int) -> torch.Tensor:
        if not self.fake_quant:
            return w
        dims = [d for d in range(w.ndim) if d != axis]
        bound = w.detach().abs().amax(dim=dims)
        scales = torch.where(bound > 0, bound / WEIGHT_MAX, torch.ones_like(bound))
        zeros = torch.zeros_like(scales, dtype=torch.int32)
        return torch.fake_quantize_per_channel_affine(w, scales, zeros, axis, -WEIGHT_MAX, WEIGHT_MAX)

    def forward(self, *inputs: torch.Tensor, all_tensors: bool = False):
        g = self.graph
        env = {name: self.quant_act(name, x) for name, x in zip(g.inputs, inputs, strict=True)}
        for op in g.ops:
            env[op.outputs[0]] = self.quant_act(op.outputs[0], self.run_op(op, env))
        if all_tensors:
            return env
        outs = [env[n] for n in g.outputs]
        return outs[0] if len(outs) == 1 else tuple(outs)

    def run_op(self, op, env) -> torch.Tensor:
        k, a = op.kind, op.options
        x = env.get(op.inputs[0])
        if k in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            w = self.const(op.inputs[1])
            if k == "CONV_2D":
                w = self.quant_weight(w, 0).permute(0, 3, 1, 2)
                groups = 1
            else:
                w = self.quant_weight(w, 3).permute(3, 0, 1, 2)
                groups = x.shape[1]
            t, b, l, r = conv_pads(self.graph, op)
            y = F.conv2d(F.pad(x, (l, r, t, b)), w, self.const(op.inputs[2]), stride=a["stride"], dilation=a["dilation"], groups=groups)
            return _activation(y, a)
        if k in ("ADD", "MUL"):
            other = env[op.inputs[1]] if op.inputs[1] in env else self.const(op.inputs[1]).reshape(())
            return _activation(x + other if k == "ADD" else x * other, a)
        if k == "CONCATENATION":
            return torch.cat([env[n] for n in op.inputs], dim=1)
        if k == "LOGISTIC":
            return torch.sigmoid(x)
        if k == "TANH":
            return torch.tanh(x)
        if k == "AVERAGE_POOL_2D":
            t, b, l, r = conv_pads(self.graph, op)  # symmetric when traced from PyTorch
            return F.avg_pool2d(x, a["kernel"], a["stride"], padding=(t, l), count_include_pad=False)
        if k == "RESIZE_BILINEAR":
            return F.interpolate(x, size=tuple(a["size"]), mode="bilinear", align_corners=a["align_corners"])
        if k == "DEPTH_TO_SPACE":
            return depth_to_space_dcr(x, a["block_size"])
        if k == "SPACE_TO_DEPTH":
            return space_to_depth_dcr(x, a["block_size"])
        if k == "PAD":
            t, b, l, r = a["pads"]
            return F.pad(x, (l, r, t, b))
        if k in ("QUANTIZE", "DEQUANTIZE"):
            return x
        raise ValueError(f"no PyTorch form for {k}")

    def export_weights(self) -> dict[str, np.ndarray]:
        return {name: self.const(name).detach().numpy().copy() for name in self.graph.constants()}


def _key(name: str) -> str:
    return name.replace(".", "/")


def _activation(y: torch.Tensor, options: dict) -> torch.Tensor:
    act = options.get("activation", "none")
    if act == "none":
        return y
    lo, hi = options["clamp"]
    return torch.clamp(y, min=lo, max=hi)


def finetune(
    quantized: Graph,
    float_module: nn.Module,
    samples: Sequence[Sequence[np.ndarray]],
    steps: int = 200,
    lr: float = 1e-4,
    seed: int = 0,
) -> tuple[Graph, list[float]]:
    """Short QAT: train the weights under fake quantization to match ``float_module``'s outputs.

    Activation scales and zero points stay those of ``quantized``; weights and
    biases are re-quantized from the trained values.  Returns the new graph
    and the loss per step.
    """
    from .params import requantize_constants

    torch.manual_seed(seed)
    module = GraphModule(quantized, fake_quant=True)
    opt = torch.optim.Adam(module.parameters(), lr=lr)
    tensors = [[torch.from_numpy(np.asarray(x, np.float32)) for x in s] for s in samples]
    with torch.no_grad():
        targets = [_as_tuple(float_module(*s)) for s in tensors]
    rng = np.random.default_rng(seed)
    losses = []
    for _ in range(steps):
        i = int(rng.integers(len(tensors)))
        outs = _as_tuple(module(*tensors[i]))
        loss = sum(F.mse_loss(o, t) for o, t in zip(outs, targets[i]))
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(loss.item())
    trained = copy.deepcopy(quantized)
    for name, value in module.export_weights().items():
        trained.tensors[name].float_data = value
    return requantize_constants(trained), losses


def _as_tuple(x):
    return tuple(x) if isinstance(x, (tuple, list)) else (x,)
