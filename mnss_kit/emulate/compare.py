"""Compare two tensor dumps tensor by tensor: where does a device (or a runtime) first diverge?

For every tensor both dumps hold, over every frame both hold:

``max_lsb``
    Largest difference in quantization steps.  Integer tensors with the same scale and zero
    point (or none) compare their stored integers; quantized tensors whose parameters differ,
    or an integer tensor against a float one, compare real values in steps of the first
    dump's scale.  Float tensors have no step: ``null`` (see ``max_abs``).
``mismatch_fraction``
    Share of values that differ at all.
``psnr``
    dB over all frames.  The peak is the integer range of the dtype (255 for 8-bit tensors)
    when integers are compared, else the value range of the first dump's tensor (at least
    1e-12).  Infinite when the tensors are identical: ``null`` in the JSON form.

Tensors are reported in the first dump's execution order; the *first diverging tensor* is the
earliest one in that order, in the earliest frame with any difference.  Recurrent state carries
a divergence into later frames, so the frame matters as much as the tensor.

A tensor both dumps hold (in their index or in any compared frame) but one frame of one dump
lacks is a difference too (``missing``): a damaged or incomplete dump must not compare clean.
A tensor only one dump ever holds is listed (``only_in_a`` / ``only_in_b``) and is no
difference: a device dump holds only what the device can read back.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..fileio import json_safe
from ..metrics.psnr import mse_psnr
from .dump import Dump, TensorEntry, merge_order, read_dump


@dataclass
class TensorStats:
    """Running statistics of one tensor over frames."""

    mode: str = ""  # "lsb" (integers), "real" (dequantized, in steps of A's scale) or "float"
    max_lsb: float = 0.0
    max_abs: float = 0.0
    mismatches: int = 0
    values: int = 0
    squared_error: float = 0.0
    peak: float = 0.0
    first_frame: int | None = None
    dtype: str = ""

    @property
    def psnr(self) -> float:
        return mse_psnr(self.squared_error / max(self.values, 1), self.peak)

    def as_json(self) -> dict:
        max_lsb = None if self.mode == "float" else (int(self.max_lsb) if self.mode == "lsb" else float(self.max_lsb))
        return {
            "max_lsb": max_lsb,
            "mismatch_fraction": self.mismatches / max(self.values, 1),
            "psnr": self.psnr,
            "max_abs": float(self.max_abs),
            "first_frame": self.first_frame,
            "compared": self.mode,
            "dtype": self.dtype,
        }


@dataclass
class Comparison:
    order: list[str]
    stats: dict[str, TensorStats]
    frames: list[int]
    first_diverging: dict | None
    only_in_a: list[str] = field(default_factory=list)
    only_in_b: list[str] = field(default_factory=list)
    missing: list[dict] = field(default_factory=list)  # {"tensor", "frame", "missing_from": "a" | "b"}, frame order

    def differs(self) -> bool:
        return self.first_diverging is not None or bool(self.missing)

    def as_json(self, a: str = "", b: str = "") -> dict:
        return json_safe({
            "a": a,
            "b": b,
            "frames": self.frames,
            "order": self.order,
            "first_diverging": self.first_diverging,
            "tensors": {name: self.stats[name].as_json() for name in self.order},
            "only_in_a": self.only_in_a,
            "only_in_b": self.only_in_b,
            "missing": self.missing,
        })


def _is_int(array: np.ndarray) -> bool:
    return np.issubdtype(array.dtype, np.integer) or array.dtype == np.bool_


def _real(array: np.ndarray, entry: TensorEntry) -> np.ndarray:
    x = array.astype(np.float64)
    if entry.scale is not None and _is_int(array):
        return (x - (entry.zero_point or 0)) * np.float64(np.float32(entry.scale))
    return x


def _int_peak(dtype: np.dtype) -> float:
    info = np.iinfo(dtype) if dtype != np.bool_ else None
    return 1.0 if info is None else float(min(info.max - info.min, 2**16 - 1))


def _same_params(ea: TensorEntry, eb: TensorEntry) -> bool:
    if ea.scale is None or eb.scale is None:
        return ea.scale is None and eb.scale is None
    return np.float32(ea.scale) == np.float32(eb.scale) and (ea.zero_point or 0) == (eb.zero_point or 0)


def _differences(a: np.ndarray, ea: TensorEntry, b: np.ndarray, eb: TensorEntry) -> tuple[str, np.ndarray, np.ndarray, float]:
    """``(mode, |difference| in steps, |difference| in real units, peak in steps)`` of one frame."""
    if _is_int(a) and _is_int(b) and _same_params(ea, eb):
        steps = np.abs(a.astype(np.int64) - b.astype(np.int64)).astype(np.float64)
        unit = np.float64(np.float32(ea.scale)) if ea.scale is not None else 1.0
        return "lsb", steps, steps * unit, _int_peak(a.dtype)
    ra, rb = _real(a, ea), _real(b, eb)
    real = np.abs(ra - rb)
    if ea.scale is not None:  # quantized in the first dump: steps of its scale
        unit = np.float64(np.float32(ea.scale))
        peak = _int_peak(a.dtype) if _is_int(a) else float(np.ptp(ra)) / unit if ra.size else 0.0
        return "real", real / unit, real, peak
    return "float", real, real, max(float(np.ptp(ra)) if ra.size else 0.0, 1e-12)


def accumulate(stats: TensorStats, frame: int, a: np.ndarray, ea: TensorEntry, b: np.ndarray, eb: TensorEntry) -> bool:
    """Add one frame of tensor ``a`` vs ``b`` to ``stats``; True if they differ anywhere."""
    if a.shape != b.shape:
        raise UserError(f"tensor '{ea.name}' frame {frame}: shape {list(a.shape)} in the first dump, {list(b.shape)} in the second")
    stats.mode, steps, real, peak = _differences(a, ea, b, eb)
    stats.peak = max(stats.peak, peak)
    stats.dtype = a.dtype.name if a.dtype == b.dtype else f"{a.dtype.name}/{b.dtype.name}"
    mismatches = int(np.count_nonzero(steps))
    stats.mismatches += mismatches
    stats.values += steps.size
    stats.squared_error += float(np.sum(steps * steps))
    if steps.size:
        stats.max_lsb = max(stats.max_lsb, float(steps.max()))
        stats.max_abs = max(stats.max_abs, float(real.max()))
    if mismatches and stats.first_frame is None:
        stats.first_frame = frame
    return mismatches > 0


def compare_dumps(a: Dump, b: Dump) -> Comparison:
    """Per-tensor statistics of ``a`` against ``b`` over their common frames."""
    frames = sorted(set(a.frames) & set(b.frames))
    if not frames:
        raise UserError(f"the dumps share no frame index ({a.root}: {sorted(a.frames)[:5]}, {b.root}: {sorted(b.frames)[:5]})")
    order: list[str] = []
    stats: dict[str, TensorStats] = {}
    names_a: list[str] = []
    names_b: set[str] = set()
    gaps: list[tuple[int, str, str]] = []  # (frame, tensor, the dump whose frame lacks it)
    first = None
    for f in frames:
        fa, fb = a.frame(f), b.frame(f)
        names_a = merge_order(names_a, _ordered(a, fa))
        names_b.update(fb)
        gaps += [(f, n, "b") for n in _ordered(a, fa) if n not in fb] + [(f, n, "a") for n in fb if n not in fa]
        for name in _ordered(a, fa):
            if name not in fb:
                continue
            if name not in stats:
                stats[name] = TensorStats()
                order.append(name)
            (xa, ea), (xb, eb) = fa[name], fb[name]
            if accumulate(stats[name], f, xa, ea, xb, eb) and first is None:
                first = {"tensor": name, "frame": f}
    order.sort(key=lambda n: names_a.index(n))
    held_a, held_b = set(names_a) | set(a.tensors), names_b | set(b.tensors)
    missing = [{"tensor": n, "frame": f, "missing_from": side} for f, n, side in gaps if n in held_a and n in held_b]
    only_a = [n for n in names_a if n not in held_b]
    only_b = sorted(n for n in names_b if n not in held_a)
    return Comparison(order, stats, frames, first, only_a, only_b, missing)


def _ordered(dump: Dump, frame: dict) -> list[str]:
    """Names of one frame in the dump's execution order (index order, then the frame's own)."""
    listed = [n for n in dump.tensors if n in frame]
    return listed + [n for n in frame if n not in dump.tensors]


def format_report(result: Comparison) -> str:
    """A fixed-width table in execution order, the first diverging tensor marked."""
    width = max([len(n) for n in result.order] + [6])
    lines = [f"{len(result.frames)} frame(s) compared, {len(result.order)} tensor(s)",
             f"   {'tensor':<{width}}  {'max_lsb':>9}  {'mismatch':>9}  {'psnr_db':>8}  first_frame"]
    first = result.first_diverging["tensor"] if result.first_diverging else None
    for name in result.order:
        s = result.stats[name].as_json()
        mark = ">> " if name == first else "   "
        lsb = "-" if s["max_lsb"] is None else (f"{s['max_lsb']}" if isinstance(s["max_lsb"], int) else f"{s['max_lsb']:.3g}")
        ff = "-" if s["first_frame"] is None else str(s["first_frame"])
        lines.append(f"{mark}{name:<{width}}  {lsb:>9}  {100 * s['mismatch_fraction']:>8.4f}%  {s['psnr']:>8.2f}  {ff}")
    if result.first_diverging:
        lines.append(f"first diverging tensor: '{first}' in frame {result.first_diverging['frame']}")
    for gap in result.missing:
        lines.append(f"tensor '{gap['tensor']}' is missing from frame {gap['frame']} of the {_DUMP_LABEL[gap['missing_from']]} dump")
    if not result.differs():
        lines.append("no differences")
    for label, names in (("only in the first dump", result.only_in_a), ("only in the second dump", result.only_in_b)):
        if names:
            lines.append(f"{label}: {', '.join(names)}")
    return "\n".join(lines)


_DUMP_LABEL = {"a": "first", "b": "second"}


def verdict(result: Comparison, a: str | Path, b: str | Path) -> str | None:
    """One line on the earliest difference, naming the tensor and frame (None when the dumps agree)."""
    gap = result.missing[0] if result.missing else None
    diverging = result.first_diverging
    if diverging and (gap is None or diverging["frame"] <= gap["frame"]):
        return f"{a} and {b} differ: first diverging tensor '{diverging['tensor']}' in frame {diverging['frame']}"
    if gap:
        return f"{a} and {b} differ: tensor '{gap['tensor']}' is missing from frame {gap['frame']} of {a if gap['missing_from'] == 'a' else b}"
    return None


def compare_paths(a: str | Path, b: str | Path) -> tuple[Comparison, dict]:
    """Open and compare two dump directories; returns the result and its JSON form."""
    result = compare_dumps(read_dump(a), read_dump(b))
    return result, result.as_json(str(a), str(b))
