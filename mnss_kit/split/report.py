"""Text and Markdown renderings of a :class:`~.plan.Placement` (every time labelled an estimate)."""

from __future__ import annotations

from ..ops.scale import scale_label
from .plan import Placement

MB = 1e6


def table(rows: list[list[str]], header: list[str], markdown: bool = False) -> str:
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
        return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(header)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(header, widths))]
    return "\n".join(lines + ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in rows])


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def stage_rows(plan: Placement) -> tuple[list[str], list[list[str]]]:
    header = ["stage", "on", "GMAC", "read MB", "write MB", "est. GPU ms", "est. NPU ms", "est. ms", "bound"]
    rows = []
    for s in plan.stages:
        npu = s.estimate_npu["estimated_ms"] if s.estimate_npu else None
        rows.append([
            s.name, s.placement, f"{s.macs / 1e9:.3f}", f"{s.bytes_read / MB:.2f}", f"{s.bytes_written / MB:.2f}",
            _ms(s.estimate_gpu["estimated_ms"]), _ms(npu), _ms(s.estimate["estimated_ms"]), s.estimate["bound"],
        ])
    for h in plan.handoffs:
        rows.append([f"handoff {h.direction} before {h.before}", "-", "-", "-", f"{h.bytes / MB:.2f}", "-", "-",
                     _ms(h.estimated_ms), "transfer"])
    rows.append(["frame total", "-", f"{sum(s.macs for s in plan.stages) / 1e9:.3f}", "-", "-", "-", "-",
                 _ms(plan.estimated_frame_ms), "-"])
    return header, rows


def boundary_rows(plan: Placement) -> tuple[list[str], list[list[str]]]:
    header = ["tensor", "producer", "consumers", "direction", "layout", "dtype", "shape", "bytes/frame"]
    rows = [
        [t.name, t.producer, ", ".join(t.consumers), t.direction, t.layout, t.dtype, "x".join(map(str, t.shape)),
         f"{t.bytes_per_frame:,}"]
        for t in plan.boundary
    ]
    return header, rows


def gpu_op_rows(plan: Placement) -> tuple[list[str], list[list[str]]]:
    """Every op kept on the GPU instead of the NPU, with the reason."""
    header = ["stage", "op", "count", "NPU accepts", "reason"]
    rows = [
        [s.name, op.op, str(op.count), "yes" if op.npu_accepts else "no", op.reason]
        for s in plan.stages if s.placement == "gpu" for op in s.ops
    ]
    return header, rows


def headline(plan: Placement) -> str:
    w, h = plan.resolution
    lw, lh = plan.lr_size
    return (f"{plan.model} on {plan.device} ({plan.soc}), placement {plan.mode}, output {w}x{h} "
            f"({scale_label(plan.scale)} from {lw}x{lh})")


def format_text(plan: Placement) -> str:
    """The placement report printed by ``mnss-kit split``."""
    header, rows = stage_rows(plan)
    parts = [headline(plan), f"ESTIMATES: {plan.estimate_note}", "", table(rows, header)]
    npu = ", ".join(plan.npu_stages()) or "none"
    parts += ["", f"NPU stages: {npu}.  Estimated frame time: {plan.estimated_frame_ms:.3f} ms "
              f"(stages {plan.estimated_stage_ms:.3f} + handoffs {plan.estimated_transfer_ms:.3f}) [estimate]"]
    if plan.boundary:
        header, rows = boundary_rows(plan)
        parts += ["", "Tensors crossing the GPU<->NPU boundary (per frame):", table(rows, header)]
    header, rows = gpu_op_rows(plan)
    if rows and plan.device_has_npu:
        parts += ["", "Ops on the GPU instead of the NPU, and why:", table(rows, header)]
    parts += [f"note: {n}" for n in plan.notes]
    return "\n".join(parts)


def format_markdown(plan: Placement, heading_level: int = 3) -> str:
    """One placement as Markdown tables (stage estimates, boundary tensors, GPU ops with reasons)."""
    mark = "#" * heading_level
    parts = [f"{mark} {headline(plan)}", ""]
    header, rows = stage_rows(plan)
    parts += [table(rows, header, markdown=True), ""]
    npu = ", ".join(plan.npu_stages()) or "none"
    parts += [f"NPU stages: {npu}. Estimated frame time: **{plan.estimated_frame_ms:.3f} ms (estimate)**.", ""]
    if plan.boundary:
        header, rows = boundary_rows(plan)
        parts += ["Tensors crossing the GPU↔NPU boundary:", "", table(rows, header, markdown=True), ""]
    header, rows = gpu_op_rows(plan)
    if rows and plan.device_has_npu:
        parts += ["Ops on the GPU instead of the NPU:", "", table(rows, header, markdown=True), ""]
    parts += [f"- {n}" for n in plan.notes]
    return "\n".join(parts).rstrip() + "\n"
