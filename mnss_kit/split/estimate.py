"""Estimated milliseconds from a device profile: a roofline per stage plus GPU<->NPU handoffs.

Per stage on a processor: ``max(compute, memory)`` where
``compute = 2 * MACs / (peak * achievable_fraction)`` (fp16 FLOP/s on the GPU, int8 op/s on
the NPU) and ``memory = bytes / (DRAM bandwidth * achievable_fraction)``.  Tensors are fp16
(2 bytes) on the GPU and int8 (1 byte) on the NPU.  A handoff costs
``transfer.latency_ms + bytes / transfer.bandwidth``.  Stages run one after another (each
needs the previous one's output), so a frame is the sum of its stages and handoffs.

These are estimates, not measurements: peaks and fractions come from public figures and
rough guesses recorded in the profile.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..ops.scale import Scale
from .dataflow import StageFlow
from .device import DeviceProfile

ESTIMATE_LABEL = "estimate"
BYTES_PER_ELEMENT = {"gpu": 2, "npu": 1}  # fp16 textures / int8 NPU tensors


@dataclass
class StageCostEstimate:
    """One stage on one processor, at one output resolution (all times are estimates)."""

    processor: str
    macs: float  # per frame
    bytes_read: float
    bytes_written: float
    compute_ms: float
    memory_ms: float
    bound: str  # "compute" or "memory"
    label: str = ESTIMATE_LABEL

    @property
    def ms(self) -> float:
        return max(self.compute_ms, self.memory_ms)

    def to_dict(self) -> dict:
        return {
            "processor": self.processor,
            "estimated_ms": self.ms,
            "estimated_compute_ms": self.compute_ms,
            "estimated_memory_ms": self.memory_ms,
            "bound": self.bound,
            "label": self.label,
        }


def stage_bytes(stage: StageFlow, processor: str, hr_size: tuple[int, int], scale: Scale) -> tuple[float, float]:
    """(bytes read, bytes written) per frame by ``stage`` on ``processor`` at output ``hr_size`` (w, h)."""
    size = BYTES_PER_ELEMENT[processor]
    inputs = sum(t.elements(hr_size, scale) for t in stage.inputs)
    outputs = sum(t.elements(hr_size, scale) for t in stage.outputs)
    between = sum(t.elements(hr_size, scale) for t in stage.intermediates)
    return size * (inputs + between + stage.weight_elements), size * (outputs + between)


def estimate_stage(
    stage: StageFlow, processor: str, device: DeviceProfile, hr_size: tuple[int, int], scale: Scale
) -> StageCostEstimate:
    """Roofline estimate of ``stage`` on ``processor`` ("gpu" or "npu") of ``device``."""
    macs = stage.macs_per_pixel * hr_size[0] * hr_size[1]
    if processor == "gpu":
        ops_per_s = device.gpu.fp16_gflops * 1e9 * device.gpu.achievable_fraction
    elif device.npu is not None:
        ops_per_s = device.npu.int8_tops * 1e12 * device.npu.achievable_fraction
    else:
        raise ValueError(f"device {device.name} has no NPU")
    read, written = stage_bytes(stage, processor, hr_size, scale)
    bytes_per_s = device.memory.bandwidth_gbps * 1e9 * device.memory.achievable_fraction
    compute_ms = 2.0 * macs / ops_per_s * 1e3
    memory_ms = (read + written) / bytes_per_s * 1e3
    bound = "compute" if compute_ms >= memory_ms else "memory"
    return StageCostEstimate(processor, macs, read, written, compute_ms, memory_ms, bound)


def handoff_ms(device: DeviceProfile, nbytes: float) -> float:
    """Estimated cost of one GPU<->NPU handoff moving ``nbytes``."""
    if device.transfer is None:
        raise ValueError(f"device {device.name} has no GPU<->NPU transfer model (no NPU)")
    return device.transfer.latency_ms + nbytes / (device.transfer.bandwidth_gbps * 1e9) * 1e3
