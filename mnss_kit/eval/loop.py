"""The evaluation loop: every method, recurrently, over every frame of every sequence.

``evaluate(methods_or_model, data_dir)`` is what the stage's entry function
(:func:`.run.evaluate_model`, ``mnss-kit eval``) and other stages run (quantize
passes ``{"fp32": ..., "int8": ...}``).  A method
is any per-frame callable ``method(frame, state) -> (output, aux, state)``
(``docs/architecture.md``); its state starts as ``None`` in each sequence.
All methods see the same frames in the same order, one frame at a time, so
per-frame numbers are paired and ratios between methods come from one run.
"""

from __future__ import annotations

import contextlib
import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch

from ..dataset import format as fmt
from ..errors import UserError
from ..fileio import atomic_directory, portable_path
from ..metrics.image import WINDOW_SIZE, ssim_image, to_image
from ..metrics.pattern import phase_offset
from ..metrics.psnr import psnr
from ..metrics.temporal import DEPTH_TOLERANCE, POOL, SHADING_FLOOR, SHADING_WEBER, if_ssim, temporal_masks, temporal_scores
from .crops import crop_frame_indices, write_crops
from .frames import EvalFrame, check_reference, frame_count, iter_frames
from .methods import Method, default_methods
from .summary import summarize


# provenance keys of meta.json "scene" that name what a sequence tests (renderer and synthetic data)
SCENE_TAGS = ("scenario", "scene", "generator", "camera", "particles", "animated_light", "cut_at")


@dataclass
class EvalOptions:
    max_frames: int | None = None
    flip: bool = False
    crops_dir: Path | None = None
    progress: bool = True
    reference: str = "box"  # fmt.REFERENCE_BUFFERS: the HR buffer the metrics compare against


@dataclass
class _MethodTrack:
    """What one method carries from frame to frame within a sequence."""

    state: object = None
    prev_output: np.ndarray | None = None


def evaluate(
    methods_or_model,
    data_dir: str | Path,
    *,
    scale: int | None = None,
    max_frames: int | None = None,
    flip: bool = False,
    crops_dir: str | Path | None = None,
    progress: bool = True,
    model_info: dict | None = None,
    reference: str = "box",
) -> dict:
    """Evaluate methods on every sequence under ``data_dir``; returns the summary dict.

    ``methods_or_model`` is a ``{name: method}`` dict, or a model (then the
    methods are model, model_nohist, bicubic and taau).  ``scale`` is the
    scale the methods expect; data at another scale is a UserError.  The
    result has ``frames``, ``methods`` (means per method), ``sequences``
    (per-sequence breakdowns), ``settings``, ``model`` (``model_info``) and
    ``per_frame`` (one row per frame and method, for the CSV).  ``reference`` chooses what the
    metrics compare against: ``box`` (hr/reference, the supersampled box filter), ``taa`` (the
    native TAA frame, hr/reference_taa) or ``4x`` (4 rotated-grid samples, hr/reference_4x).
    """
    seq_dirs = fmt.find_sequences(data_dir)
    metas = [fmt.read_meta(d) for d in seq_dirs]
    for seq_dir, meta in zip(seq_dirs, metas):
        check_reference(seq_dir, meta, reference)
    data_scale = _common_scale(seq_dirs, metas, scale)
    if isinstance(methods_or_model, torch.nn.Module):
        methods = default_methods(methods_or_model, data_scale)
    elif isinstance(methods_or_model, dict) and methods_or_model:
        methods = dict(methods_or_model)
    else:
        raise TypeError("evaluate expects a model or a non-empty {name: method} dict")
    opts = EvalOptions(max_frames, flip, Path(crops_dir) if crops_dir else None, progress, reference)
    total = sum(frame_count(m, max_frames) for m in metas)

    from tqdm import tqdm

    rows: list[dict] = []
    sequences: dict[str, dict] = {}
    # crops are staged and moved into crops_dir at the end: a failed or killed run adds none
    crops = atomic_directory(opts.crops_dir, merge=True) if opts.crops_dir else contextlib.nullcontext()
    with crops as staging, tqdm(total=total, desc="eval", unit="frame", file=sys.stderr, disable=not progress) as bar:
        staged = replace(opts, crops_dir=staging)
        for seq_dir, meta in zip(seq_dirs, metas):
            seq_rows, info = _run_sequence(seq_dir, meta, methods, staged, bar)
            rows.extend(seq_rows)
            sequences[seq_dir.name] = info
    result = summarize(rows, sequences, list(methods))
    result["settings"] = {
        "data": [portable_path(d) for d in data_dir] if isinstance(data_dir, (list, tuple)) else portable_path(data_dir),
        "scale": data_scale,
        "max_frames": max_frames,
        "reference": reference,  # box, taa or 4x: hr/reference, hr/reference_taa, hr/reference_4x
        "flip": flip,
        "if_ssim": {"pool": POOL, "depth_tolerance": DEPTH_TOLERANCE,
                    "shading_threshold": f"{SHADING_FLOOR} + {SHADING_WEBER} * display_luma"},
        "bicubic": "jitter-aware (samples placed at pixel centre + jitter)",
    }
    if model_info is not None:
        result["model"] = model_info
    result["per_frame"] = rows
    return result


def _common_scale(seq_dirs: list[Path], metas: list[fmt.SequenceMeta], expected: int | float | None) -> int | float:
    scales = {m.scale for m in metas}
    if expected is not None:
        for d, m in zip(seq_dirs, metas):
            if m.scale != expected:
                raise UserError(f"{d}: data is x{m.scale} but the model is x{expected}")
    if len(scales) != 1:
        raise UserError(f"sequences under one dataset must share a scale, found {sorted(scales)}")
    return scales.pop()


def _run_sequence(
    seq_dir: Path, meta: fmt.SequenceMeta, methods: dict[str, Method], opts: EvalOptions, bar
) -> tuple[list[dict], dict]:
    """All methods over one sequence -> (per-frame rows, sequence info)."""
    if min(meta.hr_size) < POOL * WINDOW_SIZE:
        raise UserError(f"{seq_dir}: HR frames of {meta.hr_size[0]}x{meta.hr_size[1]} are too small to evaluate "
                        f"(IF-SSIM needs at least {POOL * WINDOW_SIZE} pixels per side)")
    for method in methods.values():  # a fractional scale's output size is the sequence's, not lr * s
        if hasattr(method, "set_output_size"):
            method.set_output_size(meta.hr_size)
        if hasattr(method, "set_scale"):  # a model that reads the frame key 'scale' runs at the data's
            method.set_scale(meta.scale)
    tracks = {name: _MethodTrack() for name in methods}
    n = frame_count(meta, opts.max_frames)
    cuts = [t for t in range(1, n) if meta.frames[t].reset]
    crop_at = crop_frame_indices(n, cuts) if opts.crops_dir else set()
    rows: list[dict] = []
    reference_if_ssim: list[float] = []
    prev: EvalFrame | None = None
    for frame in iter_frames(seq_dir, meta, opts.max_frames, opts.reference):
        masks = None
        if prev is not None and not frame.reset:
            masks = temporal_masks(frame.reference, prev.reference, frame.hr_depth, prev.hr_depth, frame.hr_motion)
            reference_if_ssim.append(if_ssim(frame.reference, prev.reference, masks))
        outputs = {}
        for name, method in methods.items():
            output = _run_method(name, method, tracks[name], frame, seq_dir)
            rows.append(_frame_row(seq_dir.name, frame, name, output, tracks[name].prev_output, masks, opts.flip, meta.scale))
            tracks[name].prev_output = output
            outputs[name] = output
        if frame.index in crop_at:
            write_crops(opts.crops_dir, seq_dir.name, frame.index, frame.reference, outputs)
        prev = frame
        bar.update(1)
    finite = [v for v in reference_if_ssim if not math.isnan(v)]
    info = {
        "frames": n,
        "scale": meta.scale,
        "jitter_pattern": meta.jitter_pattern,
        "cuts": cuts,
        "tags": {k: meta.scene[k] for k in SCENE_TAGS if k in meta.scene},
        "reference_if_ssim": float(np.mean(finite)) if finite else None,
    }
    return rows, info


def _run_method(name: str, method: Method, track: _MethodTrack, frame: EvalFrame, seq_dir: Path) -> np.ndarray:
    """One frame of one method -> ``(H, W, 3)`` display image clamped to [0, 1]."""
    try:
        with torch.no_grad():
            output, _, track.state = method(frame.inputs, track.state)
    except KeyError as e:
        key = e.args[0] if e.args else None
        if isinstance(key, str) and key not in frame.inputs:
            raise UserError(f"{seq_dir}: method '{name}' needs the '{key}' buffer, which the dataset does not have") from None
        raise
    expected = (1, 3) + frame.reference.shape[:2]
    if tuple(output.shape) != expected:
        raise UserError(f"{seq_dir}: method '{name}' produced {tuple(output.shape)}, the reference is {expected} (wrong scale?)")
    if not torch.isfinite(output).all():
        raise UserError(f"{seq_dir}: method '{name}' produced NaN or infinite values at frame {frame.index}")
    return np.clip(to_image(output), 0.0, 1.0)


def _frame_row(seq: str, frame: EvalFrame, name: str, output: np.ndarray, prev_output, masks, flip: bool, scale: int) -> dict:
    ref = frame.reference
    row = {
        "sequence": seq,
        "frame": frame.index,
        "method": name,
        "reset": int(frame.reset),
        "psnr": psnr(output, ref),
        "ssim": ssim_image(output, ref),
        # the s x s phases of an LR pixel exist at an integer scale only
        "phase_offset": phase_offset(output, ref, scale) if isinstance(scale, int) else math.nan,
        "if_ssim": math.nan,
        "temporal_error": math.nan,
        "disoccluded_pixels": 0,
        "disocclusion_l1": math.nan,
        "disocclusion_mse": math.nan,
    }
    if masks is not None and prev_output is not None:
        row["if_ssim"], row["temporal_error"] = temporal_scores(output, prev_output, masks)
        hole = masks.disoccluded
        row["disoccluded_pixels"] = int(hole.sum())
        if hole.any():
            diff = (output - ref)[hole]
            row["disocclusion_l1"] = float(np.abs(diff).mean())
            row["disocclusion_mse"] = float((diff.astype(np.float64) ** 2).mean())
    if flip:
        from ..metrics.flip import flip_error

        row["flip"] = flip_error(output, ref)
    return row
