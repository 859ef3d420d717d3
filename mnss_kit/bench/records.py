"""Bench records: one per model x precision, and one per baseline, in ``bench.json``.

Every record has at least :data:`REQUIRED_KEYS`; quality keys are the means over the held-out
frames, cost keys are MACs per HR output pixel, parameters, the NPU stage's median CPU latency
and the estimated device milliseconds per shipped device profile (estimates, not measurements).
"""

from __future__ import annotations

import math

REQUIRED_KEYS = ("name", "family", "precision", "psnr", "ssim", "if_ssim", "macs_per_pixel", "cpu_ms", "device_ms")
PRECISIONS = ("fp32", "int8", "baseline")
NUMBER_KEYS = ("psnr", "ssim", "if_ssim", "macs_per_pixel")


def record_key(record: dict) -> str:
    """What makes a record unique within one bench file."""
    return f"{record['name']}/{record['precision']}"


def record_problems(record: dict) -> list[str]:
    """Why ``record`` is not a valid bench record (empty when it is)."""
    problems = [f"missing key '{k}'" for k in REQUIRED_KEYS if k not in record]
    if problems:
        return problems
    if record["precision"] not in PRECISIONS:
        problems.append(f"precision '{record['precision']}' is none of {', '.join(PRECISIONS)}")
    for key in NUMBER_KEYS:
        value = record[key]
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            problems.append(f"'{key}' must be a finite number, got {value!r}")
    if record["cpu_ms"] is not None and not isinstance(record["cpu_ms"], dict):
        problems.append("'cpu_ms' must be null or a mapping of runtime to milliseconds")
    if not isinstance(record["device_ms"], dict):
        problems.append("'device_ms' must be a mapping of device profile to estimated milliseconds")
    return problems
