"""Place every stage of a model on the GPU or the NPU of a device, with reasons and estimates.

Placements (``PLACEMENTS``):

    default    the model's own split (each stage's ``placement``; for MNSS the paper's: warp,
               inpaint, AA, insert, enhance on the GPU, reconstruction on the NPU)
    all-gpu    everything on the GPU (the fallback when there is no NPU)
    auto       the lowest estimated frame time over every assignment the NPU's ops allow

plus the named modes of each family (``Family.placements``: the default with more stages on
the NPU; MNSS's ``aa-on-npu`` moves its anti-aliasing net there).

A stage goes to the NPU only if the int8 NPU graph can hold it (``dataflow.npu_graph_refusal``:
every op in ``ops.npu_ops.NPU_OPS``, image inputs only) and the device has an NPU that accepts
every op of the stage (``DeviceProfile.npu.ops``); a stage is never cut in two.  Every op left on the GPU carries
the reason.  :class:`Placement` is plain data (``to_dict``) for reports and bundle manifests.
"""

from __future__ import annotations

import itertools
from collections import Counter
from dataclasses import asdict, dataclass, field

from ..model.families import GENERIC_PLACEMENTS, family_named, placement_modes
from ..ops.scale import Scale, lr_size_for
from .dataflow import NOTES, ModelFlow, StageFlow, npu_graph_refusal, trace_model
from .device import DeviceProfile
from .estimate import ESTIMATE_LABEL, StageCostEstimate, estimate_stage, handoff_ms

PLACEMENTS = placement_modes()
from .inputs import DEFAULT_RESOLUTION
ESTIMATE_NOTE = (
    "Every *_ms figure is an estimate from the device profile (roofline per stage plus a "
    "GPU<->NPU handoff model), not a measurement."
)


@dataclass
class OpPlacement:
    op: str  # TFLite builtin name (GRID_SAMPLE / aten.* when there is none)
    count: int
    npu_accepts: bool
    reason: str = ""  # why it runs on the GPU ("" when it runs on the NPU)


@dataclass
class StagePlacement:
    name: str
    placement: str  # "gpu" | "npu"
    model_placement: str  # what the model asks for
    npu_eligible: bool
    reason: str  # why the stage is on the GPU ("" when on the NPU)
    ops: list[OpPlacement]
    macs: float  # per frame at the target resolution
    bytes_read: float  # per frame, on the chosen processor
    bytes_written: float
    estimate: dict  # the chosen processor's estimate
    estimate_gpu: dict
    estimate_npu: dict | None  # None when the NPU cannot run the stage


@dataclass
class BoundaryTensor:
    name: str
    producer: str
    consumers: list[str]
    direction: str  # "gpu->npu" | "npu->gpu"
    layout: str  # "NHWC" for images
    dtype: str
    shape: list[int]
    bytes_per_frame: int
    next_frame: bool  # (also) needed by the next frame: the recurrent history


@dataclass
class Handoff:
    before: str  # the stage the processor switches for ("display" at the end of the frame)
    direction: str
    tensors: list[str]
    bytes: int
    estimated_ms: float
    label: str = ESTIMATE_LABEL


@dataclass
class Placement:
    model: str
    device: str
    soc: str
    mode: str
    resolution: list[int]  # output (HR) width, height
    scale: Scale
    lr_size: list[int]  # render (LR) width, height: ops.scale.lr_size_for(resolution, scale)
    stages: list[StagePlacement]
    boundary: list[BoundaryTensor]
    handoffs: list[Handoff]
    estimated_stage_ms: float
    estimated_transfer_ms: float
    estimated_frame_ms: float
    device_has_npu: bool = True
    notes: list[str] = field(default_factory=list)
    estimate_note: str = ESTIMATE_NOTE

    def to_dict(self) -> dict:
        return asdict(self)

    def npu_stages(self) -> list[str]:
        return [s.name for s in self.stages if s.placement == "npu"]


def split_model(model, device: DeviceProfile, placement: str = "default", resolution=DEFAULT_RESOLUTION,
                model_name: str = "model") -> Placement:
    """Place ``model`` (``stages()`` as in docs/architecture.md) on ``device``.

    ``resolution`` is the output (HR) size ``(width, height)`` the estimates are made for.
    """
    return plan_flow(trace_model(model), device, placement, tuple(resolution), model_name)


def plan_flow(flow: ModelFlow, device: DeviceProfile, placement: str, resolution: tuple[int, int],
              model_name: str = "model") -> Placement:
    """:func:`split_model` on an already traced model (tracing once serves many devices)."""
    own = family_named(flow.family).placements if flow.family else {}
    if placement not in (*GENERIC_PLACEMENTS, *own):
        raise ValueError(f"placement must be one of {(*GENERIC_PLACEMENTS, *own)}, got {placement!r}")
    planner = _Planner(flow, device, resolution)
    eligible = [s.name for s in flow.stages if planner.eligible(s)]
    default = {s.name for s in flow.stages if s.placement == "npu"}
    requested = {"default": default, "all-gpu": set(), **{m: default | set(more) for m, more in own.items()}}.get(placement)
    if requested is None:
        on_npu = planner.best(eligible)
    else:
        on_npu = requested & set(eligible)
    return planner.placement(on_npu, placement, requested, model_name)


class _Planner:
    def __init__(self, flow: ModelFlow, device: DeviceProfile, resolution: tuple[int, int]):
        self.flow, self.device, self.resolution = flow, device, resolution
        self.costs: dict[tuple[str, str], StageCostEstimate] = {}

    def eligible(self, stage: StageFlow) -> bool:
        return self.device.has_npu and not self.rejected(stage) and not npu_graph_refusal(stage)

    def rejected(self, stage: StageFlow) -> list[str]:
        """The stage's ops the device's NPU does not accept (a subset of ``ops.npu_ops.NPU_OPS``)."""
        return sorted({op.op for op in stage.ops if not (op.builtin and self.device.npu_accepts(op.op))})

    def cost(self, stage: StageFlow, processor: str) -> StageCostEstimate:
        key = (stage.name, processor)
        if key not in self.costs:
            self.costs[key] = estimate_stage(stage, processor, self.device, self.resolution, self.flow.scale)
        return self.costs[key]

    def frame_ms(self, on_npu: set[str]) -> float:
        stages = sum(self.cost(s, "npu" if s.name in on_npu else "gpu").ms for s in self.flow.stages)
        return stages + sum(h.estimated_ms for h in self.handoffs(on_npu)[1])

    def best(self, eligible: list[str]) -> set[str]:
        """The subset of ``eligible`` with the lowest estimated frame time (ties: fewer NPU stages)."""
        subsets = (set(c) for k in range(len(eligible) + 1) for c in itertools.combinations(eligible, k))
        return min(subsets, key=lambda on: (round(self.frame_ms(on), 9), len(on)))

    def processor(self, name: str, on_npu: set[str]) -> str:
        return "npu" if name in on_npu else "gpu"

    def handoffs(self, on_npu: set[str]) -> tuple[list[BoundaryTensor], list[Handoff]]:
        """Tensors crossing the boundary and the handoffs that carry them.

        The frame starts and ends on the GPU (renderer, display); frames repeat, so the last
        GPU segment and the first are one, and a tensor for the next frame crosses when the
        processor switches back to the GPU.
        """
        order = ["frame"] + [s.name for s in self.flow.stages] + ["display"]
        proc = {n: self.processor(n, on_npu) for n in order}
        entry = {}  # member -> the stage where its segment starts (the handoff before it)
        start = order[0]
        for prev, name in zip(order, order[1:]):
            if proc[name] != proc[prev]:
                start = name
            entry[name] = start
        entry["frame"] = "frame"
        last = entry["display"]
        entry = {n: (last if e == "frame" else e) for n, e in entry.items()}  # wrap around the frame
        crossings: dict[tuple[str, str], BoundaryTensor] = {}
        for e in self.flow.edges:
            if proc[e.producer] == proc[e.consumer]:
                continue
            key = (e.tensor.name, entry[e.consumer])
            consumer = f"{e.consumer}.{e.consumer_input}" + (" (next frame)" if e.next_frame else "")
            if key in crossings:
                crossings[key].consumers.append(consumer)
                continue
            image = e.tensor.grid != "other"
            shape = list(e.tensor.shape_nhwc(self.resolution, self.flow.scale))
            crossings[key] = BoundaryTensor(
                name=e.tensor.name, producer=e.producer, consumers=[consumer],
                direction=f"{proc[e.producer]}->{proc[e.consumer]}", layout="NHWC" if image else "vector",
                dtype="int8" if image else "float32", shape=shape,
                bytes_per_frame=e.tensor.elements(self.resolution, self.flow.scale) * (1 if image else 4),
                next_frame=e.next_frame,
            )
        handoffs = []
        switches = [n for prev, n in zip(order, order[1:]) if proc[n] != proc[prev]]
        for name in switches:
            tensors = [t for (tname, at), t in crossings.items() if at == name]
            nbytes = sum(t.bytes_per_frame for t in tensors)
            direction = f"{'npu' if proc[name] == 'gpu' else 'gpu'}->{proc[name]}"
            cost = handoff_ms(self.device, nbytes)
            handoffs.append(Handoff(name, direction, [t.name for t in tensors], nbytes, cost))
        return list(crossings.values()), handoffs

    def stage_reason(self, stage: StageFlow, mode: str, on_npu: set[str]) -> str:
        if stage.name in on_npu:
            return ""
        if not self.device.has_npu:
            return "the device profile has no NPU: all stages run on the GPU"
        rejected = self.rejected(stage)
        wanted = " the model places it on the NPU, but" if stage.placement == "npu" else ""
        if rejected:
            return f"{wanted} the NPU does not accept {', '.join(rejected)}; a stage stays whole".strip()
        if npu_graph_refusal(stage):
            return f"{wanted} {npu_graph_refusal(stage)}".strip()
        if mode == "auto":
            alternative = self.frame_ms(on_npu | {stage.name})
            return (f"auto: estimated frame {alternative:.3f} ms with {stage.name} on the NPU vs "
                    f"{self.frame_ms(on_npu):.3f} ms chosen")
        if mode == "all-gpu":
            return "placement all-gpu keeps every stage on the GPU"
        return f"placement {mode} keeps {stage.name} on the GPU (the model's split)"

    def op_reasons(self, stage: StageFlow, stage_reason: str, on_gpu: bool) -> list[OpPlacement]:
        out = []
        for op, count in Counter(op.op for op in stage.ops).items():
            builtin = any(o.builtin for o in stage.ops if o.op == op)
            accepts = builtin and self.device.npu_accepts(op)
            reason = ""
            if on_gpu:
                if not self.device.has_npu:
                    reason = "the device has no NPU"
                elif not builtin:
                    reason = NOTES.get(op, f"{op} has no TFLite builtin op")
                elif not accepts:
                    reason = f"{op} is not in the device's npu.ops"
                elif self.rejected(stage):
                    reason = f"accepted by the NPU, but {stage.name} also needs ops the NPU rejects"
                elif npu_graph_refusal(stage):
                    reason = f"accepted by the NPU, but {npu_graph_refusal(stage)}"
                else:
                    reason = f"accepted by the NPU, but {stage_reason}"
            out.append(OpPlacement(op, count, accepts, reason))
        return out

    def placement(self, on_npu: set[str], mode: str, requested: set[str] | None, model_name: str) -> Placement:
        stages = []
        for s in self.flow.stages:
            proc = self.processor(s.name, on_npu)
            chosen, gpu = self.cost(s, proc), self.cost(s, "gpu")
            npu = self.cost(s, "npu") if self.eligible(s) else None
            reason = self.stage_reason(s, mode, on_npu)
            stages.append(StagePlacement(
                name=s.name, placement=proc, model_placement=s.placement, npu_eligible=self.eligible(s),
                reason=reason, ops=self.op_reasons(s, reason, proc == "gpu"), macs=chosen.macs,
                bytes_read=chosen.bytes_read, bytes_written=chosen.bytes_written, estimate=chosen.to_dict(),
                estimate_gpu=gpu.to_dict(), estimate_npu=npu.to_dict() if npu else None,
            ))
        boundary, handoffs = self.handoffs(on_npu)
        stage_ms = sum(s.estimate["estimated_ms"] for s in stages)
        transfer_ms = sum(h.estimated_ms for h in handoffs)
        notes = []
        if not self.device.has_npu:
            notes.append(f"{self.device.name} has no usable NPU: falling back to all-gpu")
        missed = sorted((requested or set()) - on_npu)
        if missed:
            notes.append(f"requested on the NPU but not accepted there: {', '.join(missed)} (run on the GPU)")
        return Placement(
            model=model_name, device=self.device.name, soc=self.device.soc, mode=mode,
            resolution=list(self.resolution), scale=self.flow.scale,
            lr_size=list(lr_size_for(self.resolution, self.flow.scale)), stages=stages, boundary=boundary,
            handoffs=handoffs, estimated_stage_ms=stage_ms, estimated_transfer_ms=transfer_ms,
            estimated_frame_ms=stage_ms + transfer_ms, device_has_npu=self.device.has_npu, notes=notes,
        )
