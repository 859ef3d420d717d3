"""Device profiles: what a phone's GPU, NPU, memory and GPU<->NPU handoff can do.

A profile is ``mnss_kit/configs/devices/NAME.yaml``::

    schema: 1
    name: snapdragon_8_gen_1
    soc: Qualcomm Snapdragon 8 Gen 1
    gpu:      {name: Adreno 730, fp16_gflops: 3350, achievable_fraction: 0.3}
    npu:      {name: Hexagon, int8_tops: 26, achievable_fraction: 0.2, ops: [CONV_2D, ...]}
    memory:   {bandwidth_gbps: 51.2, achievable_fraction: 0.6}
    transfer: {latency_ms: 0.3, bandwidth_gbps: 5.0}
    sources:  ["where each figure comes from", ...]

``npu: null`` (and no ``transfer``) describes a phone without a usable NPU.  Every figure is
a public peak or a rough estimate; the ``achievable_fraction`` factors turn peaks into what a
real kernel reaches.  Estimates made from a profile are estimates, and are labelled so.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from pathlib import Path

from ..config import from_dict, read_yaml, resolve_config_path
from ..errors import UserError
from ..ops.npu_ops import NPU_OPS

SCHEMA_VERSION = 1


def _check_fraction(value: float, what: str) -> None:
    if not 0.0 < value <= 1.0:
        raise ValueError(f"{what} must be in (0, 1], got {value}")


def _check_positive(value: float, what: str) -> None:
    if not value > 0.0:
        raise ValueError(f"{what} must be > 0, got {value}")


@dataclass
class GpuSpec:
    name: str
    fp16_gflops: float  # peak fp16 throughput, GFLOP/s (one MAC = 2 FLOP)
    achievable_fraction: float  # share of the peak a compute shader reaches

    def __post_init__(self):
        _check_positive(self.fp16_gflops, "gpu.fp16_gflops")
        _check_fraction(self.achievable_fraction, "gpu.achievable_fraction")


@dataclass
class NpuSpec:
    name: str
    int8_tops: float  # peak int8 throughput, TOP/s (one MAC = 2 ops)
    achievable_fraction: float
    ops: list[str] = field(default_factory=list)  # the ops.npu_ops.NPU_OPS this NPU accepts

    def __post_init__(self):
        _check_positive(self.int8_tops, "npu.int8_tops")
        _check_fraction(self.achievable_fraction, "npu.achievable_fraction")
        if not self.ops:
            raise ValueError("npu.ops must list at least one TFLite builtin op")


@dataclass
class MemorySpec:
    bandwidth_gbps: float  # peak DRAM bandwidth, GB/s (1e9 bytes/s)
    achievable_fraction: float

    def __post_init__(self):
        _check_positive(self.bandwidth_gbps, "memory.bandwidth_gbps")
        _check_fraction(self.achievable_fraction, "memory.achievable_fraction")


@dataclass
class TransferSpec:
    """One GPU<->NPU handoff costs ``latency_ms`` (fence, cache maintenance, NPU invocation)
    plus the bytes crossing at ``bandwidth_gbps``."""

    latency_ms: float
    bandwidth_gbps: float

    def __post_init__(self):
        if self.latency_ms < 0.0:
            raise ValueError(f"transfer.latency_ms must be >= 0, got {self.latency_ms}")
        _check_positive(self.bandwidth_gbps, "transfer.bandwidth_gbps")


@dataclass
class DeviceProfile:
    schema: int
    name: str
    soc: str
    gpu: GpuSpec
    memory: MemorySpec
    npu: NpuSpec | None = None
    transfer: TransferSpec | None = None
    description: str = ""
    sources: list[str] = field(default_factory=list)

    def __post_init__(self):
        if self.schema != SCHEMA_VERSION:
            raise ValueError(f"schema must be {SCHEMA_VERSION}, got {self.schema}")
        if self.npu is not None and self.transfer is None:
            raise ValueError("a profile with an npu needs a 'transfer' section (GPU<->NPU handoff cost)")

    @property
    def has_npu(self) -> bool:
        return self.npu is not None

    def npu_accepts(self, op: str) -> bool:
        return self.npu is not None and op in self.npu.ops


def device_from_dict(data: dict, source: str = "device profile") -> DeviceProfile:
    """Validate plain data into a :class:`DeviceProfile` (unknown keys rejected; every NPU op
    must be one the int8 NPU graph can hold, ``ops.npu_ops.NPU_OPS``)."""
    profile = from_dict(DeviceProfile, data, source=source)
    if profile.npu is not None:
        for op in profile.npu.ops:
            if op not in NPU_OPS:
                close = difflib.get_close_matches(op, sorted(NPU_OPS), n=1)
                hint = f" (did you mean {close[0]}?)" if close else f" (one of: {', '.join(NPU_OPS)})"
                raise UserError(f"{source}: npu.ops lists '{op}', which is not an op of the int8 NPU graph{hint}")
    return profile


def load_device(name_or_path: str | Path) -> DeviceProfile:
    """A profile from a YAML path or a bare name under ``mnss_kit/configs/devices/``."""
    path = resolve_config_path(str(name_or_path), "devices")
    return device_from_dict(read_yaml(path), source=str(path))


def device_names() -> list[str]:
    """Names of the shipped device profiles, sorted."""
    from ..config import CONFIG_DIR

    return sorted(p.stem for p in (CONFIG_DIR / "devices").glob("*.yaml"))
