"""Assemble a bundle: write its files into a staging directory, build the manifest, check, publish.

:func:`write_bundle` is the last step of the export stage's entry function (:func:`.run.export`).  The bundle appears at ``out`` only
after :func:`mnss_kit.export.check.check_bundle` passes on the staging copy, through
:func:`mnss_kit.fileio.atomic_directory`, so a failure at any point leaves nothing partial.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import UserError
from ..fileio import atomic_directory, json_text
from ..gpu.glsl import flatten
from ..gpu.plan import WEIGHT_ALIGNMENT, WEIGHTS_FILE, pack_weights
from ..model.checkpoint import code_version
from ..ops import conventions
from ..ops.jitter import jitter_sequence, period, subpixel_index
from .boundary import boundary_entry
from .check import check_bundle
from .golden import TOLERANCES, GoldenFrame, write_golden
from .manifest import FORMAT, FORMAT_VERSION, MANIFEST_NAME, file_table
from .npu_files import read_tflite
from .npu_stage import NpuArtifacts
from .sequence import write_sequence

TFLITE_NAME, ONNX_NAME = "npu.tflite", "npu_qdq.onnx"


@dataclass
class BundleParts:
    """Everything a bundle is made from.  ``lr_size`` is ``(width, height)``; ``stages`` is
    ``[(name, placement)]`` in execution order; ``placement`` the split stage's plain data (or None)."""

    model: dict
    plan: dict  # the family's GPU plan (``Family.gpu_plan``): passes, weight blocks, resources, schedule, optional debug views
    scale: int | float  # 2, 3, 4 or a quality mode such as 1.5 (then ``hr_size`` is given)
    lr_size: tuple[int, int]
    jitter_pattern: str
    stages: list[tuple[str, str]]
    npu: NpuArtifacts
    profile: str
    golden: list[GoldenFrame]
    golden_source: str
    placement: dict | None = None
    sequence: tuple[list[dict], str] | None = None  # recorded input frames to carry, and where they came from
    hr_size: tuple[int, int] | None = None  # (W, H) at a fractional scale (round(lr * s) is not always it); else lr * s


def write_bundle(out: str | Path, parts: BundleParts, overwrite: bool = False) -> dict:
    """Write the bundle directory ``out``; returns its manifest."""
    with atomic_directory(out, overwrite=overwrite) as staging:
        manifest = stage_bundle(staging, parts)
        problems = check_bundle(staging)
        if problems:
            raise _check_failure(problems, parts.npu)
    return manifest


def _check_failure(problems: list[str], npu: NpuArtifacts) -> Exception:
    """A UserError for a problem in NPU files copied unchanged from a quantize directory (the
    user's input); anything else is the writer producing what its own checker rejects: a bug."""
    directory = npu.quantization.get("directory")
    for line in problems:
        if directory and line.split()[0].rstrip(":") in (TFLITE_NAME, ONNX_NAME):  # lines start with the file's name
            return UserError(f"{Path(directory) / line}")
    return RuntimeError("exported bundle fails its check:\n" + "\n".join(problems))


def stage_bundle(root: Path, parts: BundleParts) -> dict:
    """Write every file and the manifest into ``root`` (an empty directory); returns the manifest."""
    (root / TFLITE_NAME).write_bytes(parts.npu.tflite)
    (root / ONNX_NAME).write_bytes(parts.npu.onnx)
    passes = parts.plan["passes"]
    (root / "shaders").mkdir()
    for entry in passes:
        (root / entry["file"]).write_text(flatten(Path(entry["file"]).name))
    weights, blocks = pack_weights(parts.plan["weights"])
    (root / WEIGHTS_FILE).write_bytes(weights)
    table = jitter_table(parts.jitter_pattern, parts.scale)
    golden = write_golden(root, parts.golden, parts.scale, table)
    manifest = build_manifest(parts, passes, blocks, table, golden)
    if parts.sequence is not None:
        frames, source = parts.sequence
        manifest["sequence"] = write_sequence(root, frames, parts.plan["resources"], parts.scale, table, source)
    manifest["files"] = file_table(root)
    (root / MANIFEST_NAME).write_text(json_text(manifest))
    return manifest


def jitter_table(pattern: str, scale: int) -> list[dict]:
    """One period of the jitter pattern: offset (LR pixels) and sampled sub-pixel per frame."""
    n = period(pattern, scale)
    offsets = jitter_sequence(pattern, scale, n)
    subs = subpixel_index(offsets.astype(np.float32), scale)
    return [{"index": t, "offset": [float(v) for v in offsets[t]], "subpixel": [int(v) for v in subs[t]]} for t in range(n)]


def build_manifest(parts: BundleParts, passes: list[dict], blocks: list[dict], table: list[dict], golden: list[dict]) -> dict:
    s = parts.scale
    w, h = parts.lr_size
    npu_model = read_tflite(parts.npu.tflite, TFLITE_NAME)
    npu_in, npu_out = npu_model.inputs[0], npu_model.outputs[0]
    in_q, out_q = npu_model.tensors[npu_in].plain_qparams(), npu_model.tensors[npu_out].plain_qparams()
    schedule = parts.plan["schedule"]
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "toolkit": {"name": "mnss-kit", "version": __version__, "code_version": code_version()},
        "model": parts.model,
        "scale": s,
        "lr_size": [w, h],
        "hr_size": list(parts.hr_size) if parts.hr_size is not None else [w * s, h * s],
        "conventions": conventions_section(),
        "jitter": {
            "pattern": parts.jitter_pattern,
            "period": len(table),
            "units": conventions.JITTER_UNITS,
            "rule": "consecutive frames use consecutive entries, wrapping after the last (frame t uses entry "
                    "(t + phase) mod period, any phase); 'subpixel' is the (dx, dy) of the s x s tile the sample "
                    "lands in, the shaders' u_subpixel",
            "sequence": table,
        },
        "stages": stages_section(parts.stages, schedule["steps"]),
        "gpu": {
            "language": "GLSL ES 3.10",
            "passes": passes,
            "weights": {"file": WEIGHTS_FILE, "dtype": "float32", "byte_order": "little",
                        "alignment": WEIGHT_ALIGNMENT, "blocks": blocks},
        },
        "npu": {
            "model": TFLITE_NAME,
            "onnx": ONNX_NAME,
            "layout": conventions.LAYOUT_NPU,
            "onnx_layout": conventions.LAYOUT_TORCH,
            "inputs": npu_model.inputs,
            "outputs": npu_model.outputs,
            "tensors": [{"name": t.name, "shape": list(t.shape), "dtype": t.dtype, "scale": float(t.scale[0]), "zero_point": int(t.zero_point[0])}
                        for t in npu_model.activations()],
            "requantization_profile": parts.profile,
            "quantization": parts.npu.quantization,
        },
        "boundary": [
            boundary_entry("npu_input", npu_in, "gpu->npu", npu_model.tensors[npu_in].shape, npu_model.tensors[npu_in].dtype, *in_q, "npu_input"),
            boundary_entry("npu_output", npu_out, "npu->gpu", npu_model.tensors[npu_out].shape, npu_model.tensors[npu_out].dtype, *out_q, "npu_output"),
        ],
        "resources": parts.plan["resources"],
        "schedule": schedule,
        **({"debug_views": parts.plan["debug_views"]} if parts.plan.get("debug_views") else {}),
        "placement": parts.placement,
        "golden": {
            "profile": parts.profile,
            "gpu_reference": "mnss_kit.gpu.reference.ReferencePasses (numpy, fp16 storage rounding)",
            "npu_reference": f"LiteRT {parts.profile} kernels",
            "source": parts.golden_source,
            "tolerances": TOLERANCES,
            "frames": golden,
        },
    }


def conventions_section() -> dict:
    return {
        "image_origin": "top-left, row 0 at the top",
        "pixel_center": conventions.PIXEL_CENTER,
        "motion": {"units": conventions.MOTION_UNITS, "resolution": "lr", "points_to": conventions.MOTION_POINTS_TO,
                   "y_axis": conventions.MOTION_Y_AXIS, "jittered": False},
        "depth": "linear view depth normalised to [0, 1]: (z - near) / (far - near)",
        "colour": "display values in [0, 1] (tone-mapped, as the model was trained)",
        "warp_border": conventions.WARP_BORDER,
        "npu_layout": conventions.LAYOUT_NPU,
        "sizes": "[width, height]",
    }


def stages_section(stages: list[tuple[str, str]], steps: list[dict]) -> list[dict]:
    """Model stages in execution order, each with the schedule steps that run it."""
    out = []
    for name, placement in stages:
        labels = [step["label"] for step in steps if step["stage"] == name]
        entry = {"name": name, "placement": placement, "steps": labels}
        if placement == "npu":
            entry["model"] = TFLITE_NAME
        out.append(entry)
    return out
