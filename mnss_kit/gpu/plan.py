"""Building blocks of a bundle's GPU plan: weight blocks, shader entries, schedule steps, uniforms.

A family's plan builder (``Family.gpu_plan``) returns, with these, the plain data a bundle
carries and :mod:`.interpret` runs::

    {"passes": [...], "weights": (bytes, [block entries]), "resources": [...], "schedule": {...}}

and optionally ``"debug_views": [...]``: resources an app may show and how to colour them (the
manifest schema's ``debug_views``).

Bindings, uniforms, workgroup sizes and formats come from :data:`mnss_kit.gpu.passes.PASSES` (one
file per pass); nothing here restates them, and a step's uniforms must be ones its pass declares.  Resource names in a step's ``bind`` refer to ``resources``; ``weights:NAME`` to a
block of the weight file.  Per-frame uniform values (``{"frame": KEY}``) are: ``offset`` /
``subpixel`` (this frame's jitter entry), ``previous_offset`` / ``previous_subpixel`` (the
previous frame's) and ``reset`` (1 on a camera cut or the first frame, from the engine).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

from ..ops.runtimes import DEFAULT_RUNTIME, get_runtime
from . import passes as P
from .weights import Conv3x3

WEIGHTS_FILE = "gpu_weights.bin"
WEIGHTS_PREFIX = "weights:"  # a bind target naming a block of the weight file
WEIGHT_ALIGNMENT = 256  # bytes; the largest SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT GL ES allows
MAX_GROUPS_X = 4096  # workgroups along x for the word grid (the shader folds y into the index)
FRAME_KEYS = ("offset", "subpixel", "previous_offset", "previous_subpixel", "reset")  # per-frame uniform values


@dataclass(frozen=True)
class NpuBoundary:
    """The int8 tensors crossing to and from the NPU: ``real = scale * (q - zero_point)``, and the
    runtime (``ops.runtimes.RUNTIMES``) whose QUANTIZE rounding the pack reproduces."""

    input_scale: float
    input_zero_point: int
    output_scale: float
    output_zero_point: int
    profile: str = DEFAULT_RUNTIME

    def __post_init__(self):
        get_runtime(self.profile)  # ValueError on an unknown name


def pack_weights(blocks: list[tuple[str, Conv3x3]]) -> tuple[bytes, list[dict]]:
    """The weight file (little-endian float32, blocks aligned to :data:`WEIGHT_ALIGNMENT`) and its block entries.

    Each block is ``pack_conv3x3`` of one conv: ``(rows, 4)`` float32, the layout ``conv3x3.glsl``
    reads; ``conv`` records the unpacked shape so a reader can undo the packing.
    """
    data, entries = bytearray(), []
    for name, conv in blocks:
        data += b"\0" * (-len(data) % WEIGHT_ALIGNMENT)
        packed = np.ascontiguousarray(conv.packed(), dtype="<f4")
        raw = packed.tobytes()
        entries.append({
            "name": name,
            "offset": len(data),
            "bytes": len(raw),
            "shape": list(packed.shape),
            "sha256": hashlib.sha256(raw).hexdigest(),
            "conv": {"out_channels": conv.out_channels, "in_channels": conv.in_channels, "kernel": [3, 3],
                     "layout": "conv3x3.glsl (mnss_kit.gpu.weights.pack_conv3x3)"},
        })
        data += raw
    return bytes(data), entries


def pass_entries(used: set[str]) -> list[dict]:
    """Every shader in ``used`` (pass names), in :data:`~.passes.PASS_ORDER`: entry file, workgroup
    size, grid, bindings, uniforms."""
    out = []
    for name in (n for n in P.PASS_ORDER if n in used):
        spec = P.PASSES[name]
        out.append({
            "name": name,
            "file": f"shaders/{spec.entry}",
            "workgroup_size": list(spec.local_size),
            "grid": spec.grid,
            "bindings": [{"name": b.name, "kind": b.kind, "unit": b.unit, "format": b.format, "array": b.array} for b in spec.bindings],
            "uniforms": list(spec.uniforms),
            "exact": spec.exact,
        })
    return out


def word_count(lr_size: tuple[int, int], scale: int, channels: int) -> int:
    """32-bit words of an int8 NHWC (1, H, W, ``channels``) tensor at the HR size."""
    return -(-lr_size[0] * scale * lr_size[1] * scale * channels // 4)


def groups(grid: str, local: tuple[int, int, int], lr_size: tuple[int, int], scale: int, depth: int = 1,
           words: int = 0, hr_size: tuple[int, int] | None = None) -> list[int]:
    """Workgroup counts of a pass over ``grid`` (``words``: the word count for the ``words`` grid);
    the ``hr`` grid covers ``hr_size`` when given (a fractional scale), else ``lr_size`` times ``scale``."""
    w, h = lr_size
    if grid == "words":
        n = -(-words // local[0])
        gx = min(n, MAX_GROUPS_X)
        return [gx, -(-n // gx), 1]
    if grid == "hr":
        w, h = (w * scale, h * scale) if hr_size is None else (int(hr_size[0]), int(hr_size[1]))
    return [-(-w // local[0]), -(-h // local[1]), depth]


def step(name: str, label: str, stage_name: str, bind: dict, uniforms: dict, lr_size, scale, depth: int = 1,
         skip_on_reset: bool = False, words: int = 0, hr_size=None) -> dict:
    """One GPU step of the schedule: pass ``name`` for model stage ``stage_name`` (``hr_size``: the HR
    grid's size at a fractional scale).  ``ValueError`` for a uniform the pass does not declare."""
    spec = P.PASSES[name]
    unknown = sorted(set(uniforms) - set(spec.uniforms))
    if unknown:
        raise ValueError(f"{name} declares no uniform {', '.join(unknown)} (gpu/passes/{name}.py: {', '.join(spec.uniforms)})")
    return {
        "kind": "gpu",
        "pass": name,
        "label": label,
        "stage": stage_name,
        "bind": bind,
        "uniforms": uniforms,
        "groups": groups(spec.grid, spec.local_size, lr_size, scale, depth, words, hr_size),
        "skip_on_reset": skip_on_reset,
    }


def warp_step(stage_name: str, label: str, lr_size, scale: int) -> dict:
    """warp_pass on the resources of the same names (history, prev_depth, motion -> warped,
    warped_depth), skipped on a reset frame: the history warp every recurrent family runs."""
    bind = {name: name for name in ("history", "prev_depth", "motion", "warped", "warped_depth")}
    uniforms = {"u_scale": const(scale), "u_subpixel": per_frame("subpixel"), "u_prev_jitter": per_frame("previous_offset"),
                "u_prev_subpixel": per_frame("previous_subpixel")}
    return step("warp_pass", label, stage_name, bind, uniforms, lr_size, scale, skip_on_reset=True)


def const(value) -> dict:
    return {"value": value}


def per_frame(key: str) -> dict:
    if key not in FRAME_KEYS:
        raise ValueError(f"unknown per-frame uniform value '{key}' (one of: {', '.join(FRAME_KEYS)})")
    return {"frame": key}


def quantize_uniforms(scale: float, zero_point: int, profile: str) -> dict:
    """Schedule uniforms of ``passes.quantize_uniforms``, as constants."""
    return {k: const(v) for k, v in P.quantize_uniforms(scale, zero_point, profile).items()}


def texture(name: str, size, fmt: str, role: str, note: str, channels: int) -> dict:
    """A 2D texture entry of a bundle's resources (``size`` is ``[width, height]``)."""
    return {"name": name, "kind": "texture2d", "size": size, "format": fmt, "channels": channels, "role": role,
            "description": note}


def boundary_buffer(name: str, words: int, note: str) -> dict:
    """A buffer of ``words`` 32-bit words that crosses the GPU<->NPU boundary."""
    return {"name": name, "kind": "buffer", "bytes": words * 4, "words": words, "element": "uint", "role": "boundary",
            "description": note}
