"""Float PyTorch module (NCHW) -> float :class:`~.graph.Graph` (NHWC), by torch.fx tracing.

Accepted (each becomes ops of ``mnss_kit.ops.npu_ops.NPU_OPS``, the table split asks
too): ``nn.Conv2d`` (bias or not, groups 1 or depthwise, zero padding),
ReLU / ReLU6 / Hardtanh / clamp (folded into the producing convolution or
addition), ``PixelShuffle`` / ``PixelUnshuffle``, ``torch.cat`` on channels,
elementwise ``+`` and ``*`` (tensor or scalar), sigmoid, tanh, average pooling
without padding, bilinear resizing, identity and dropout, on NCHW image inputs.  Anything
else is a ``UserError`` naming the node.  A module whose function needs an op outside these (a
slice of its input) may offer ``graph_form()``, the same function in these ops, which is traced.

PixelShuffle's channel order (``c * r^2 + k``) is not DEPTH_TO_SPACE's
(``k * C + c``).  The convolution that produces a PixelShuffle input writes its
output channels in DEPTH_TO_SPACE order, and every convolution reading a
reordered tensor (such as a SPACE_TO_DEPTH output) permutes its input
channels, so no data is moved at run time.
"""

from __future__ import annotations

import operator
from typing import Sequence

import numpy as np
import torch
import torch.fx
import torch.nn as nn
import torch.nn.functional as F
from torch.fx.passes.shape_prop import ShapeProp

from ..errors import UserError
from .graph import Graph, Op, Tensor, same_padding

ADD_FUNCTIONS = (operator.add, torch.add, operator.iadd)
MUL_FUNCTIONS = (operator.mul, torch.mul, operator.imul)
UNARY_ACTIVATIONS = {torch.sigmoid: "LOGISTIC", F.sigmoid: "LOGISTIC", torch.tanh: "TANH", F.tanh: "TANH"}
IDENTITY_MODULES = (nn.Identity, nn.Dropout)


def depth_perm(perm: np.ndarray, block: int) -> np.ndarray:
    """Channel order of a SPACE_TO_DEPTH output (or required DEPTH_TO_SPACE input).

    ``perm`` is the order of the ``C`` shallow channels (graph channel -> PyTorch
    channel).  Graph channel ``k * C + c`` of the deep tensor holds PyTorch
    (Pixel(Un)Shuffle) channel ``perm[c] * r^2 + k``.
    """
    r2 = block * block
    c = len(perm)
    return np.array([perm[j % c] * r2 + j // c for j in range(c * r2)], dtype=np.int64)


def trace(module: nn.Module, example_inputs: Sequence[torch.Tensor]) -> Graph:
    """Trace ``module`` on ``example_inputs`` (NCHW float32) into a float graph (NHWC).

    A module with a ``graph_form()`` method is traced as the module it returns (the same function in
    ops the graph has).  Raises ``UserError`` for an op the int8 exporters cannot express.
    """
    graph_form = getattr(module, "graph_form", None)
    module = (graph_form() if callable(graph_form) else module).eval()
    try:
        gm = torch.fx.symbolic_trace(module)
    except Exception as e:  # fx raises many types for dynamic control flow
        raise UserError(f"cannot trace {type(module).__name__} with torch.fx ({type(e).__name__}: {e})") from None
    with torch.no_grad():
        ShapeProp(gm).propagate(*[t.float() for t in example_inputs])
    return _Converter(gm).run()


class _Converter:
    def __init__(self, gm: torch.fx.GraphModule):
        self.gm = gm
        self.modules = dict(gm.named_modules())
        self.tensors: dict[str, Tensor] = {}
        self.ops: list[Op] = []
        self.inputs: list[str] = []
        self.values: dict[torch.fx.Node, object] = {}  # node -> tensor name or python scalar
        self.requests: dict[torch.fx.Node, np.ndarray] = {}

    # -- helpers -------------------------------------------------------
    def fail(self, node: torch.fx.Node, what: str) -> UserError:
        return UserError(f"cannot quantize node '{node.name}' ({what}): not supported by the int8 NPU graph")

    def target_name(self, node: torch.fx.Node) -> str:
        if node.op == "call_module":
            return type(self.modules[node.target]).__name__
        return getattr(node.target, "__name__", str(node.target))

    def shape(self, node: torch.fx.Node) -> tuple[int, ...]:
        meta = node.meta.get("tensor_meta")
        if meta is None or not hasattr(meta, "shape"):
            raise self.fail(node, "output is not a single tensor")
        if len(meta.shape) != 4:
            raise self.fail(node, f"a tensor of shape {list(meta.shape)}, not an NCHW image")
        n, c, h, w = tuple(meta.shape)
        return (n, h, w, c)

    def new_tensor(self, node: torch.fx.Node, perm: np.ndarray, name: str | None = None) -> str:
        name = name or node.name
        self.tensors[name] = Tensor(name=name, shape=self.shape(node), channel_order=perm)
        return name

    def const(self, name: str, data: np.ndarray) -> str:
        self.tensors[name] = Tensor(name=name, shape=tuple(data.shape), float_data=data.astype(np.float32))
        return name

    def perm(self, name: str) -> np.ndarray:
        return self.tensors[name].channel_order

    def value(self, arg) -> object:
        if isinstance(arg, torch.fx.Node):
            return self.values[arg]
        return arg

    def emit(self, kind: str, inputs: list[str], output: str, node: torch.fx.Node, **options) -> Op:
        op = Op(kind, inputs, [output], options, source=node.name)
        self.ops.append(op)
        return op

    # -- channel-order requests (backward) ------------------------------
    def request(self, node, perm: np.ndarray) -> None:
        """Ask ``node`` to produce its channels in ``perm`` order (best effort)."""
        if not isinstance(node, torch.fx.Node):
            return
        old = self.requests.get(node)
        if old is not None:
            if not np.array_equal(old, perm):
                raise UserError(f"node '{node.name}' feeds two PixelShuffles that need different channel orders")
            return
        self.requests[node] = perm
        kind = self.kind(node)
        if kind in ("unary", "identity", "pool", "resize", "activation"):
            self.request(node.args[0], perm)
        elif kind in ("add", "mul"):
            for a in node.args[:2]:
                self.request(a, perm)
        elif kind == "conv" and self.is_depthwise(node) and self.modules[node.target].out_channels == self.modules[node.target].in_channels:
            self.request(node.args[0], perm)

    # -- classification -------------------------------------------------
    def kind(self, node: torch.fx.Node) -> str:
        t = node.target
        if node.op == "placeholder":
            return "input"
        if node.op == "output":
            return "output"
        if node.op == "call_module":
            m = self.modules[t]
            if isinstance(m, nn.Conv2d):
                return "conv"
            if isinstance(m, (nn.ReLU, nn.ReLU6, nn.Hardtanh)):
                return "activation"
            if isinstance(m, (nn.Sigmoid, nn.Tanh)):
                return "unary"
            if isinstance(m, nn.PixelShuffle):
                return "pixel_shuffle"
            if isinstance(m, nn.PixelUnshuffle):
                return "pixel_unshuffle"
            if isinstance(m, nn.AvgPool2d):
                return "pool"
            if isinstance(m, nn.Upsample):
                return "resize"
            if isinstance(m, IDENTITY_MODULES):
                return "identity"
            return "unsupported"
        if node.op == "call_function":
            if t in ADD_FUNCTIONS:
                return "add"
            if t in MUL_FUNCTIONS:
                return "mul"
            if t in UNARY_ACTIVATIONS:
                return "unary"
            if t in (F.relu, torch.relu, F.relu6, F.hardtanh, torch.clamp, torch.clip):
                return "activation"
            if t in (torch.cat, torch.concat):
                return "cat"
            if t is F.pixel_shuffle:
                return "pixel_shuffle"
            if t is F.pixel_unshuffle:
                return "pixel_unshuffle"
            if t is F.avg_pool2d:
                return "pool"
            if t is F.interpolate:
                return "resize"
            return "unsupported"
        if node.op == "call_method":
            return {
                "add": "add", "add_": "add", "mul": "mul", "mul_": "mul", "sigmoid": "unary", "tanh": "unary",
                "relu": "activation", "clamp": "activation", "clip": "activation", "contiguous": "identity",
            }.get(t, "unsupported")
        return "unsupported"

    def is_depthwise(self, node) -> bool:
        m = self.modules[node.target]
        return m.groups > 1 and m.groups == m.in_channels

    # -- main -------------------------------------------------------------
    def run(self) -> Graph:
        nodes = list(self.gm.graph.nodes)
        for node in nodes:
            kind = self.kind(node)
            if kind == "unsupported":
                raise self.fail(node, self.target_name(node))
            if kind == "pixel_shuffle":
                block = self.block(node)
                c = self.shape(node)[3]
                self.request(node.args[0], depth_perm(np.arange(c), block))
        outputs: list[str] = []
        for node in nodes:
            kind = self.kind(node)
            if kind == "output":
                outputs = self.outputs(node)
                continue
            handler = getattr(self, f"do_{kind}")
            self.values[node] = handler(node)
        graph = Graph(self.tensors, self.ops, self.inputs, outputs)
        graph.validate()
        return graph

    def outputs(self, node) -> list[str]:
        result = node.args[0]
        items = result if isinstance(result, (tuple, list)) else [result]
        names = []
        for item in items:
            name = self.value(item)
            if not isinstance(name, str) or name in self.inputs or self.tensors[name].is_constant:
                raise UserError(f"output '{getattr(item, 'name', item)}' must be computed by the network")
            perm = self.perm(name)
            if not np.array_equal(perm, np.arange(len(perm))):
                raise UserError(f"output '{item.name}' has its channels reordered (a PixelUnshuffle output?); end the network with a convolution")
            names.append(name)
        return names

    # -- node handlers ------------------------------------------------
    def do_input(self, node):
        self.inputs.append(self.new_tensor(node, np.arange(self.shape(node)[3])))
        return node.name

    def do_identity(self, node):
        return self.value(node.args[0])

    def do_conv(self, node):
        m: nn.Conv2d = self.modules[node.target]
        x = self.value(node.args[0])
        depthwise = self.is_depthwise(node)
        if m.groups != 1 and not depthwise:
            raise self.fail(node, f"grouped Conv2d with groups={m.groups}")
        if m.padding_mode != "zeros":
            raise self.fail(node, f"Conv2d padding_mode={m.padding_mode}")
        w = m.weight.detach().float().numpy()  # (O, I/groups, KH, KW)
        b = m.bias.detach().float().numpy() if m.bias is not None else np.zeros(m.out_channels, np.float32)
        p_in = self.perm(x)
        if depthwise:
            mult = m.out_channels // m.in_channels
            p_out = np.array([p_in[j // mult] * mult + j % mult for j in range(m.out_channels)])
            w_ir = np.transpose(w[:, 0], (1, 2, 0))[None][..., p_out]  # (1, KH, KW, O)
        else:
            p_out = self.requests.get(node, np.arange(m.out_channels))
            w_ir = np.transpose(w, (0, 2, 3, 1))[p_out][..., p_in]  # OHWI, both axes in graph order
        x, padding = self.pad_for(node, x, m)
        out = self.new_tensor(node, p_out)
        wname = self.const(f"{node.name}.weight", w_ir)
        bname = self.const(f"{node.name}.bias", b[p_out])
        kind = "DEPTHWISE_CONV_2D" if depthwise else "CONV_2D"
        options = dict(stride=tuple(m.stride), dilation=tuple(m.dilation), padding=padding, activation="none")
        if depthwise:
            options["depth_multiplier"] = m.out_channels // m.in_channels
        self.emit(kind, [x, wname, bname], out, node, **options)
        return out

    def pad_for(self, node, x: str, m: nn.Conv2d) -> tuple[str, str]:
        """Express PyTorch's symmetric zero padding as TFLite SAME / VALID, or an explicit PAD.

        Returns the (possibly padded) input and the convolution's padding mode.
        """
        _, h, w, _ = self.tensors[x].shape
        kh, kw = m.kernel_size
        if isinstance(m.padding, str):
            if m.padding == "valid":
                return x, "VALID"
            ph, pw = ((m.dilation[0] * (kh - 1)) // 2, (m.dilation[1] * (kw - 1)) // 2)
        else:
            ph, pw = m.padding
        if ph == 0 and pw == 0:
            return x, "VALID"
        same = [same_padding(size, k, s, d) for size, k, s, d in ((h, kh, m.stride[0], m.dilation[0]), (w, kw, m.stride[1], m.dilation[1]))]
        if same == [(ph, ph), (pw, pw)]:
            return x, "SAME"
        return self.pad(node, x, (ph, ph, pw, pw)), "VALID"

    def pad(self, node, x: str, pads: tuple[int, int, int, int]) -> str:
        n, h, w, c = self.tensors[x].shape
        name = f"{node.name}.pad"
        self.tensors[name] = Tensor(name=name, shape=(n, h + pads[0] + pads[1], w + pads[2] + pads[3], c), channel_order=self.perm(x))
        self.emit("PAD", [x], name, node, pads=pads)
        return name

    def do_activation(self, node):
        lo, hi = self.activation_bounds(node)
        x = self.value(node.args[0])
        producer = next((op for op in self.ops if op.outputs == [x]), None)
        source = node.args[0]
        foldable = (
            producer is not None
            and producer.kind in ("CONV_2D", "DEPTHWISE_CONV_2D", "ADD", "MUL")
            and producer.options.get("activation") == "none"
            and len(source.users) == 1
            and x not in self.inputs
        )
        if not foldable:
            raise self.fail(node, "activation that does not directly follow a convolution, addition or multiplication")
        if lo is not None and lo > 0 or hi is not None and hi < 0:
            raise self.fail(node, f"clamp to [{lo}, {hi}], a range that excludes 0")
        producer.options["activation"] = _activation_name(lo, hi)
        producer.options["clamp"] = (lo, hi)
        return x

    def activation_bounds(self, node) -> tuple[float | None, float | None]:
        t = node.target
        if node.op == "call_module":
            m = self.modules[t]
            if isinstance(m, nn.ReLU6):
                return 0.0, 6.0
            if isinstance(m, nn.Hardtanh):
                return float(m.min_val), float(m.max_val)
            return 0.0, None
        if t in (F.relu, torch.relu) or t == "relu":
            return 0.0, None
        if t is F.relu6:
            return 0.0, 6.0
        if t is F.hardtanh:
            return float(node.kwargs.get("min_val", node.args[1] if len(node.args) > 1 else -1.0)), float(
                node.kwargs.get("max_val", node.args[2] if len(node.args) > 2 else 1.0)
            )
        lo = node.kwargs.get("min", node.args[1] if len(node.args) > 1 else None)
        hi = node.kwargs.get("max", node.args[2] if len(node.args) > 2 else None)
        if isinstance(lo, torch.fx.Node) or isinstance(hi, torch.fx.Node):
            raise self.fail(node, "clamp with tensor bounds")
        return (None if lo is None else float(lo)), (None if hi is None else float(hi))

    def do_unary(self, node):
        x = self.value(node.args[0])
        fn = node.target if node.op == "call_function" else None
        if node.op == "call_module":
            kind = "LOGISTIC" if isinstance(self.modules[node.target], nn.Sigmoid) else "TANH"
        elif node.op == "call_method":
            kind = "LOGISTIC" if node.target == "sigmoid" else "TANH"
        else:
            kind = UNARY_ACTIVATIONS[fn]
        out = self.new_tensor(node, self.perm(x))
        self.emit(kind, [x], out, node)
        return out

    def do_add(self, node):
        return self.binary(node, "ADD")

    def do_mul(self, node):
        return self.binary(node, "MUL")

    def binary(self, node, kind: str):
        if node.kwargs.get("alpha", 1) != 1:
            raise self.fail(node, "add with alpha")
        a, b = (self.value(v) for v in node.args[:2])
        if not isinstance(a, str):
            a, b = b, a
        if not isinstance(a, str):
            raise self.fail(node, "arithmetic on constants only")
        if isinstance(b, (int, float)):
            b = self.const(f"{node.name}.scalar", np.full((1, 1, 1, 1), float(b), np.float32))
        elif not isinstance(b, str):
            raise self.fail(node, f"{kind.lower()} with a {type(b).__name__} operand")
        else:
            if self.tensors[a].shape != self.tensors[b].shape:
                raise self.fail(node, f"{kind.lower()} of shapes {self.tensors[a].shape} and {self.tensors[b].shape} (broadcasting)")
            if not np.array_equal(self.perm(a), self.perm(b)):
                raise self.fail(node, f"{kind.lower()} of tensors whose channels are ordered differently (a PixelUnshuffle output?)")
        out = self.new_tensor(node, self.perm(a))
        self.emit(kind, [a, b], out, node, activation="none")
        return out

    def do_cat(self, node):
        items = node.args[0]
        dim = node.kwargs.get("dim", node.args[1] if len(node.args) > 1 else 0)
        if dim not in (1, -3):
            raise self.fail(node, f"torch.cat along dim {dim} (only channels, dim=1)")
        names = [self.value(v) for v in items]
        perms, offset = [], 0
        for n in names:
            perms.append(self.perm(n) + offset)
            offset += self.tensors[n].shape[3]
        out = self.new_tensor(node, np.concatenate(perms))
        self.emit("CONCATENATION", names, out, node, axis=3)
        return out

    def block(self, node) -> int:
        if node.op == "call_module":
            m = self.modules[node.target]
            return int(m.upscale_factor if isinstance(m, nn.PixelShuffle) else m.downscale_factor)
        return int(node.args[1] if len(node.args) > 1 else next(iter(node.kwargs.values())))

    def do_pixel_shuffle(self, node):
        x = self.value(node.args[0])
        r = self.block(node)
        p_in = self.perm(x)
        c = len(p_in) // (r * r)
        p_out = p_in[:c] // (r * r)
        if not np.array_equal(depth_perm(p_out, r), p_in):
            raise UserError(
                f"PixelShuffle '{node.name}' reads '{node.args[0].name}', whose channels cannot be reordered for "
                "DEPTH_TO_SPACE; feed PixelShuffle from a convolution (optionally through activations or additions)"
            )
        out = self.new_tensor(node, p_out)
        self.emit("DEPTH_TO_SPACE", [x], out, node, block_size=r)
        return out

    def do_pixel_unshuffle(self, node):
        x = self.value(node.args[0])
        r = self.block(node)
        out = self.new_tensor(node, depth_perm(self.perm(x), r))
        self.emit("SPACE_TO_DEPTH", [x], out, node, block_size=r)
        return out

    def do_pool(self, node):
        x = self.value(node.args[0])
        if node.op == "call_module":
            m = self.modules[node.target]
            k, s, p, ceil, include = m.kernel_size, m.stride, m.padding, m.ceil_mode, m.count_include_pad
            divisor = m.divisor_override
        else:
            names = ("kernel_size", "stride", "padding", "ceil_mode", "count_include_pad", "divisor_override")
            defaults = dict(stride=None, padding=0, ceil_mode=False, count_include_pad=True, divisor_override=None)
            args = dict(zip(names, node.args[1:]))
            args.update(node.kwargs)
            k = args["kernel_size"]
            s, p, ceil, include, divisor = (args.get(n, defaults[n]) for n in names[1:])
        k, s, p = _pair(k), _pair(s if s else k), _pair(p)
        if ceil or divisor is not None:
            raise self.fail(node, "average pooling with ceil_mode or divisor_override")
        padding = "VALID"
        if p != (0, 0):
            _, h, w, _ = self.tensors[x].shape
            same = [same_padding(h, k[0], s[0]), same_padding(w, k[1], s[1])]
            if include or same != [(p[0], p[0]), (p[1], p[1])]:
                raise self.fail(node, "average pooling with padding counted in the average (use count_include_pad=False and SAME-like padding)")
            padding = "SAME"
        out = self.new_tensor(node, self.perm(x))
        self.emit("AVERAGE_POOL_2D", [x], out, node, kernel=k, stride=s, padding=padding)
        return out

    def do_resize(self, node):
        x = self.value(node.args[0])
        if node.op == "call_module":
            m = self.modules[node.target]
            mode, align = m.mode, bool(m.align_corners)
        else:
            mode = node.kwargs.get("mode", node.args[3] if len(node.args) > 3 else "nearest")
            align = bool(node.kwargs.get("align_corners") or False)
            if node.kwargs.get("antialias"):
                raise self.fail(node, "interpolate with antialias")
        if mode != "bilinear":
            raise self.fail(node, f"interpolate mode '{mode}' (only bilinear)")
        out = self.new_tensor(node, self.perm(x))
        self.emit("RESIZE_BILINEAR", [x], out, node, size=self.shape(node)[1:3], align_corners=align, half_pixel_centers=not align)
        return out


def _pair(v) -> tuple[int, int]:
    return (int(v), int(v)) if isinstance(v, int) else (int(v[0]), int(v[1]))


def _activation_name(lo: float | None, hi: float | None) -> str:
    if lo == 0.0 and hi is None:
        return "relu"
    if lo == 0.0 and hi == 6.0:
        return "relu6"
    if lo == -1.0 and hi == 1.0:
        return "relu_n1_to_1"
    return "clamp"
