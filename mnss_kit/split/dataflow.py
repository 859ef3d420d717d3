"""What each stage of a model computes and moves: TFLite ops, tensors, MACs, and the data flow.

:func:`trace_model` runs one small frame through the model with a hook on every stage
(``model.stages()``) and a dispatch-level recorder that sees every ATen op the stage runs,
including those inside helper functions.  Each op is mapped to the TFLite builtin the NPU
graph would need (``grid_sample`` has none); :func:`npu_graph_refusal` says whether the int8
NPU graph (``ops.npu_ops.NPU_OPS``, what ``quantize`` writes) can hold a stage at all.  Tensors are described by the grid they live on
(``hr``, ``lr`` or ``other``) and their channel count, so sizes can be evaluated at any
output resolution afterwards.

What is listed as an op: work on per-pixel tensors (rank >= 3).  Arithmetic on rank <= 2
tensors (the jitter's sub-pixel index, pixel-centre coordinate vectors) becomes shader
uniforms or graph constants, views and copies are free, and constant factories are folded.
ReLU/clamp directly after a convolution or an elementwise add/sub/mul is fused into it
(as the int8 exporter does).

Memory-traffic model (used by ``estimate``): a stage reads its inputs and weights and writes
the outputs some other stage (or the display, or the next frame) consumes; every convolution
writes its output and the next op reads it back; elementwise, activation, layout and
resampling ops are fused into the pass that reads or writes their operands.
"""

from __future__ import annotations

import contextlib
import inspect
from dataclasses import dataclass, field

import torch
from torch import nn
from torch.utils._python_dispatch import TorchDispatchMode

from ..model.families import family_of
from ..model.family import example_frame
from ..model.macs import count_macs
from ..model.taau import hr_dims
from ..ops.npu_ops import NPU_OPS
from ..ops.scale import Scale, lr_size_for

# ATen op -> TFLite builtin
TFLITE_OPS = {
    "add": "ADD", "sub": "SUB", "rsub": "SUB", "mul": "MUL", "div": "DIV", "abs": "ABS", "neg": "NEG",
    "exp": "EXP", "sqrt": "SQRT", "pow": "POW", "floor": "FLOOR", "remainder": "FLOOR_MOD",
    "maximum": "MAXIMUM", "minimum": "MINIMUM", "sigmoid": "LOGISTIC", "tanh": "TANH",
    "avg_pool2d": "AVERAGE_POOL_2D", "max_pool2d": "MAX_POOL_2D", "max_pool2d_with_indices": "MAX_POOL_2D",
    "mean": "MEAN", "sum": "SUM", "cat": "CONCATENATION", "stack": "PACK", "permute": "TRANSPOSE",
    "upsample_bilinear2d": "RESIZE_BILINEAR", "upsample_nearest2d": "RESIZE_NEAREST_NEIGHBOR",
    "pixel_shuffle": "DEPTH_TO_SPACE", "pixel_unshuffle": "SPACE_TO_DEPTH", "constant_pad_nd": "PAD",
    # a one-pixel SYMMETRIC mirror pad repeats the edge texel, as replication padding does
    "replication_pad2d": "MIRROR_PAD", "reflection_pad2d": "MIRROR_PAD",
    "gather": "GATHER_ND", "where": "SELECT_V2", "slice": "STRIDED_SLICE", "select": "STRIDED_SLICE",
    "eq": "EQUAL", "ne": "NOT_EQUAL", "lt": "LESS", "le": "LESS_EQUAL", "gt": "GREATER", "ge": "GREATER_EQUAL",
    "bitwise_and": "LOGICAL_AND", "logical_and": "LOGICAL_AND", "bitwise_or": "LOGICAL_OR",
    "logical_or": "LOGICAL_OR", "bitwise_not": "LOGICAL_NOT", "logical_not": "LOGICAL_NOT", "_to_copy": "CAST",
}
# ATen ops with no TFLite builtin, under the name the report uses
NO_BUILTIN = {"grid_sampler_2d": "GRID_SAMPLE", "grid_sampler": "GRID_SAMPLE"}
FREE_OPS = {
    "view", "_unsafe_view", "reshape", "_reshape_alias", "expand", "unsqueeze", "squeeze", "alias", "detach",
    "t", "contiguous", "clone", "lift_fresh", "lift_fresh_copy", "as_strided", "unbind", "split", "chunk",
}
CONSTANT_OPS = {
    "arange", "ones_like", "zeros_like", "full", "full_like", "empty", "empty_like", "zeros", "ones",
    "new_zeros", "new_ones", "new_full", "new_empty", "scalar_tensor", "linspace",
}
ACTIVATIONS = {"relu", "clamp", "hardtanh", "clamp_min", "clamp_max"}
FUSES_ACTIVATION = {"CONV_2D", "DEPTHWISE_CONV_2D", "TRANSPOSE_CONV", "ADD", "SUB", "MUL"}
CONVOLUTIONS = {"CONV_2D", "DEPTHWISE_CONV_2D", "TRANSPOSE_CONV"}
NOTES = {
    "GRID_SAMPLE": "bilinear gather at per-pixel offsets (grid_sample) has no TFLite builtin; "
    "most NPUs cannot run it",
}


@dataclass
class TensorInfo:
    """A tensor at the traced size: ``grid`` is ``hr`` / ``lr`` (spatial, NCHW) or ``other``."""

    name: str
    grid: str
    channels: int
    traced_shape: tuple[int, ...]

    def shape_nhwc(self, hr_size: tuple[int, int], scale: Scale) -> tuple[int, ...]:
        """NHWC shape at output size ``hr_size`` (width, height); the LR size is the render size of
        ``hr_size`` (``ops.scale.lr_size_for``: ``hr / s`` for a multiple of an integer scale)."""
        if self.grid == "other":
            return self.traced_shape
        w, h = lr_size_for(hr_size, scale) if self.grid == "lr" else hr_size
        return (1, h, w, self.channels)

    def elements(self, hr_size: tuple[int, int], scale: Scale) -> int:
        n = 1
        for d in self.shape_nhwc(hr_size, scale):
            n *= d
        return n


@dataclass
class OpRecord:
    op: str  # TFLite builtin name (or GRID_SAMPLE / aten.* when there is none)
    aten: str
    builtin: bool  # a TFLite builtin exists
    traced_shape: tuple[int, ...]  # output shape at the traced size (NCHW)


@dataclass
class StageFlow:
    name: str
    placement: str  # the model's own placement ("gpu" / "npu")
    ops: list[OpRecord] = field(default_factory=list)
    inputs: list[TensorInfo] = field(default_factory=list)
    outputs: list[TensorInfo] = field(default_factory=list)  # those consumed downstream
    intermediates: list[TensorInfo] = field(default_factory=list)  # materialised conv outputs
    weight_elements: int = 0
    macs_per_pixel: float = 0.0  # per HR output pixel (model.macs: learned conv + fixed-function)


@dataclass
class Edge:
    """``tensor`` flows from ``producer`` (a stage, or ``frame``: the renderer) to
    ``consumer`` (a stage, or ``display``); ``next_frame`` for the recurrent state."""

    tensor: TensorInfo
    producer: str
    consumer: str
    consumer_input: str
    next_frame: bool = False


@dataclass
class ModelFlow:
    scale: Scale  # the scale traced at (a quality mode such as 1.5 for a family that takes any)
    stages: list[StageFlow]
    edges: list[Edge]
    family: str = ""  # the model's family (``model.families.FAMILIES``): its placement modes

    def stage(self, name: str) -> StageFlow:
        return next(s for s in self.stages if s.name == name)


def npu_graph_refusal(stage: StageFlow) -> str:
    """Why the int8 NPU graph cannot hold ``stage`` on any device, or "" if it can: an op with no
    entry in ``ops.npu_ops.NPU_OPS``, or an input that is not an image (the graph takes NCHW
    tensors in, as NHWC; a per-frame vector such as the jitter has no place in it)."""
    missing = sorted({op.op for op in stage.ops if op.op not in NPU_OPS})
    if missing:
        return f"the int8 NPU graph has no {', '.join(missing)}"
    vectors = [t.name for t in stage.inputs if len(t.traced_shape) != 4]
    if vectors:
        return f"the int8 NPU graph takes images only, not {', '.join(vectors)}"
    return ""


def trace_model(model: nn.Module, lr_size: tuple[int, int] = (8, 12)) -> ModelFlow:
    """Run one frame of LR size ``lr_size`` (h, w) through ``model`` and record every stage.

    ``model`` follows docs/architecture.md: ``stages()``, ``initial_state(frame)``,
    ``model(frame, state) -> (output, aux, state)``, ``scale`` (any, for a family that takes fractional ones).
    """
    h, w = lr_size
    scale = model.scale
    frame = example_frame(family_of(model), h, w, scale, torch.Generator().manual_seed(0))
    state = model.initial_state(frame)
    with _graph_forms(model):  # the stages as the int8 graph holds them (quantize.trace)
        tracer = _Tracer(list(model.stages()), (h, w), scale)
        with torch.no_grad(), tracer.recording():
            output, _, next_state = model(frame, state)
        macs = count_macs(model, lr_size=lr_size)
    flow = tracer.build(frame, state, next_state, output)
    flow.family = model.config.family
    for stage in flow.stages:
        cost = macs.stages.get(stage.name)
        stage.macs_per_pixel = cost.total if cost is not None else 0.0
    return flow


@contextlib.contextmanager
def _graph_forms(model: nn.Module):
    """Each stage that offers ``graph_form()`` (the same function in ops the NPU graph has, e.g.
    ntaau_lr's steering net with a detail branch, which otherwise slices its input) swapped in for
    the block: its ops and MACs are those of the exported graph.  The model is restored after."""
    swapped = {name: module for name, module, _ in model.stages() if callable(getattr(module, "graph_form", None))}
    try:
        for name, module in swapped.items():
            form = module.graph_form()
            if form is not module:
                form.placement = module.placement
                setattr(model, name, form)
        yield
    finally:
        for name, module in swapped.items():
            setattr(model, name, module)


class _Recorder(TorchDispatchMode):
    """Keeps every ATen call (function, args, kwargs, output) made while active."""

    def __init__(self):
        super().__init__()
        self.calls: list[tuple] = []

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        out = func(*args, **kwargs)
        self.calls.append((func, args, kwargs, out))
        return out


def _tensors(value) -> list[torch.Tensor]:
    if isinstance(value, torch.Tensor):
        return [value]
    if isinstance(value, (list, tuple)):
        return [t for v in value for t in _tensors(v)]
    if isinstance(value, dict):
        return [t for v in value.values() for t in _tensors(v)]
    return []


class _Tracer:
    """One recorder over the whole frame; stage hooks mark which calls belong to which stage.

    Calls outside every stage are glue (e.g. zeroing the history on a cut); a stage input made
    by glue is traced back through it to the stage outputs, frame buffers or state it came from.
    """

    def __init__(self, stages, lr_hw: tuple[int, int], scale: Scale):
        self.stages = stages
        self.scale = scale
        self.lr_hw, self.hr_hw = lr_hw, hr_dims(lr_hw, scale)
        self.recorder = _Recorder()
        self.bound: dict[str, dict] = {}  # stage -> {input name: value}
        self.results: dict[str, tuple] = {}  # stage -> outputs
        self.spans: dict[str, tuple[int, int]] = {}  # stage -> [first, last) call index

    @contextlib.contextmanager
    def recording(self):
        handles = []
        for name, module, _ in self.stages:
            handles.append(module.register_forward_pre_hook(self._pre(name), with_kwargs=True))
            handles.append(module.register_forward_hook(self._post(name)))
        try:
            with self.recorder:
                yield
        finally:
            for handle in handles:
                handle.remove()

    def _pre(self, name):
        def hook(module, args, kwargs):
            self.bound[name] = dict(inspect.signature(module.forward).bind(*args, **kwargs).arguments)
            self.spans[name] = (len(self.recorder.calls), -1)

        return hook

    def _post(self, name):
        def hook(module, args, output):
            self.results[name] = output if isinstance(output, tuple) else (output,)
            self.spans[name] = (self.spans[name][0], len(self.recorder.calls))

        return hook

    def describe(self, name: str, t: torch.Tensor) -> TensorInfo:
        shape = tuple(t.shape)
        grid = "other"
        if t.dim() == 4:
            grid = {self.hr_hw: "hr", self.lr_hw: "lr"}.get(shape[-2:], "other")
        return TensorInfo(name, grid, shape[1] if grid != "other" else 0, shape)

    def build(self, frame: dict, state: dict, next_state: dict, output: torch.Tensor) -> ModelFlow:
        self.sources: dict[int, tuple[str, str, torch.Tensor]] = {}  # id -> (kind, name, tensor)
        for name, _, _ in self.stages:
            outs = self.results[name]
            for i, t in enumerate(outs):
                if isinstance(t, torch.Tensor):
                    self.sources[id(t)] = ("stage", f"{name}.out" if len(outs) == 1 else f"{name}.out{i}", t)
        for key, t in frame.items():
            self.sources.setdefault(id(t), ("frame", f"frame.{key}", t))
        for key, t in state.items():
            self.sources.setdefault(id(t), ("state", key, t))
        in_stage = {i for first, last in self.spans.values() for i in range(first, last)}
        self.glue = {}
        for i, call in enumerate(self.recorder.calls):
            if i not in in_stage:
                for t in _tensors(call[3]):
                    self.glue[id(t)] = call
        edges = []
        for name, _, _ in self.stages:
            for param, value in self.bound[name].items():
                for t in _tensors(value):
                    edges += self._edges_into(name, param, t, next_state)
        edges += self._edges_into("display", "output", output, next_state)
        flows = [self._stage_flow(name, module, placement, edges) for name, module, placement in self.stages]
        return ModelFlow(scale=self.scale, stages=flows, edges=_unique(edges))

    def _roots(self, t: torch.Tensor, seen=None) -> list[tuple[str, str, torch.Tensor]]:
        """The stage outputs, frame buffers and state entries ``t`` was made from."""
        if id(t) in self.sources:
            return [self.sources[id(t)]]
        call = self.glue.get(id(t))
        if call is None:  # a constant
            return []
        seen = set() if seen is None else seen
        roots = []
        for arg in _tensors(call[1]) + _tensors(call[2]):
            if id(arg) not in seen:
                seen.add(id(arg))
                roots += self._roots(arg, seen)
        return roots

    def _edges_into(self, consumer: str, param: str, t: torch.Tensor, next_state: dict) -> list[Edge]:
        edges = []
        for kind, name, root in self._roots(t):
            if kind == "state":  # made by the previous frame: whatever made this frame's next state
                for kind2, name2, root2 in self._roots(next_state[name]):
                    producer = name2.split(".")[0] if kind2 == "stage" else "frame"
                    edges.append(Edge(self.describe(name2, root2), producer, consumer, param, next_frame=True))
            else:
                producer = name.split(".")[0] if kind == "stage" else "frame"
                edges.append(Edge(self.describe(name, root), producer, consumer, param))
        return edges

    def _stage_flow(self, name, module, placement, edges) -> StageFlow:
        flow = StageFlow(name=name, placement=placement)
        for e in edges:
            if e.consumer == name and all(t.name != e.tensor.name for t in flow.inputs):
                flow.inputs.append(e.tensor)
        consumed = {e.tensor.name for e in edges if e.producer == name}
        outs = self.results[name]
        for i, t in enumerate(outs):
            label = f"{name}.out" if len(outs) == 1 else f"{name}.out{i}"
            if label in consumed:
                flow.outputs.append(self.describe(label, t))
        first, last = self.spans[name]
        flow.ops, conv_outputs = _map_ops(self.recorder.calls[first:last])
        out_ids = {id(t) for t in outs}
        flow.intermediates = [
            self.describe(f"{name}.conv{i}", t) for i, (t, aliases) in enumerate(conv_outputs) if not aliases & out_ids
        ]
        flow.weight_elements = sum(p.numel() for p in module.parameters())
        return flow


def _unique(edges: list[Edge]) -> list[Edge]:
    seen, out = set(), []
    for e in edges:
        key = (e.tensor.name, e.producer, e.consumer, e.consumer_input, e.next_frame)
        if key not in seen:
            seen.add(key)
            out.append(e)
    return out


def _map_ops(calls) -> tuple[list[OpRecord], list[tuple[torch.Tensor, set[int]]]]:
    """TFLite ops for recorded ATen calls, and each convolution output (a materialised tensor)
    with the ids of the tensors that alias it through fused activations."""
    records, conv_outputs = [], []
    fused_into: dict[int, int] = {}  # id(output an activation can fuse into) -> index in conv_outputs or -1
    for func, args, kwargs, out in calls:
        aten = func.overloadpacket.__name__
        first = out[0] if isinstance(out, (tuple, list)) else out
        if not isinstance(first, torch.Tensor) or aten in FREE_OPS or aten in CONSTANT_OPS:
            continue
        if first.dim() < 3:  # per-frame scalars: uniforms or constants
            continue
        if aten in ACTIVATIONS:
            src = args[0] if isinstance(args[0], torch.Tensor) else None
            if src is not None and id(src) in fused_into:
                conv = fused_into[id(src)]
                if conv >= 0:
                    conv_outputs[conv][1].add(id(first))
                continue
            op = _activation_op(aten, args, kwargs)
        elif aten == "convolution":
            op = _conv_op(args)
            conv_outputs.append((first, {id(first)}))
        else:
            op = TFLITE_OPS.get(aten) or NO_BUILTIN.get(aten) or f"aten.{aten}"
        if op in FUSES_ACTIVATION:
            fused_into[id(first)] = len(conv_outputs) - 1 if op in CONVOLUTIONS else -1
        builtin = aten in TFLITE_OPS or aten in ACTIVATIONS or aten == "convolution"
        records.append(OpRecord(op=op, aten=f"aten.{aten}", builtin=builtin, traced_shape=tuple(first.shape)))
    return records, conv_outputs


def _conv_op(args) -> str:
    x, _, _, _, _, _, transposed, _, groups = args[:9]
    if transposed:
        return "TRANSPOSE_CONV"
    if groups > 1 and groups == x.shape[1]:
        return "DEPTHWISE_CONV_2D"
    return "CONV_2D"


def _activation_op(aten, args, kwargs) -> str:
    """A stand-alone ReLU or clamp as the TFLite op that expresses it."""
    if aten == "relu":
        return "RELU"
    if aten == "clamp_min":
        return "RELU" if args[1] == 0 else "MAXIMUM"
    if aten == "clamp_max":
        return "MINIMUM"
    lo = args[1] if len(args) > 1 else kwargs.get("min", -1.0 if aten == "hardtanh" else None)
    hi = args[2] if len(args) > 2 else kwargs.get("max", 1.0 if aten == "hardtanh" else None)
    named = {(0, None): "RELU", (0, 6): "RELU6", (-1, 1): "RELU_N1_TO_1", (0, 1): "RELU_0_TO_1"}
    key = (None if lo is None else float(lo), None if hi is None else float(hi))
    return named.get(key, "MINIMUM" if lo is None else "MAXIMUM")
