"""An analytic sequence with exact ground truth, for tests and for checking an exporter.

A procedural texture scrolls under a panning camera while a square object
moves on its own path (so there is disocclusion), optionally with a camera
cut.  Colour is evaluated analytically at the jittered sample positions, the
HR reference is a 4x4 supersampled box filter, and motion vectors are exact.
No GPU needed: it writes the same on-disk format as the renderer.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..ops.jitter import jitter_sequence
from .format import FORMAT_NAME, FORMAT_VERSION, FrameMeta, SequenceMeta, write_buffer, write_meta

NEAR, FAR = 0.1, 10.0
BACKGROUND_Z, OBJECT_Z = 6.0, 2.0


def _texture(u: np.ndarray, v: np.ndarray, phase: float) -> np.ndarray:
    """Linear RGB in [0, ~1.2] of a world-space point (HR pixel units)."""
    checker = ((np.floor(u / 6.0) + np.floor(v / 6.0)) % 2).astype(np.float32)
    r = 0.5 + 0.4 * np.sin(u * 0.37 + phase) * np.cos(v * 0.21)
    g = 0.3 + 0.5 * checker
    b = 0.5 + 0.4 * np.sin((u + v) * 0.9)
    return np.stack([r, g, b], axis=-1).astype(np.float32)


def _camera(t: int, cut_at: int | None) -> np.ndarray:
    """Camera offset (HR pixels) at frame t; jumps at a cut."""
    base = np.array([2.3 * t, 0.9 * t + 0.2 * t * t / 8.0])
    if cut_at is not None and t >= cut_at:
        base = base + np.array([517.0, 211.0])
    return base


def _object(t: int, width: int) -> np.ndarray:
    """Top-left corner (screen, HR pixels) of the moving square."""
    return np.array([width * 0.2 + 3.1 * t, width * 0.15 + 1.7 * t])


def _shade(x: np.ndarray, y: np.ndarray, t: int, size: int, width: int, cut_at) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Colour, view depth and motion (HR px) at screen points x, y (HR pixel units)."""
    cam = _camera(t, cut_at)
    cam_prev = _camera(max(t - 1, 0), cut_at)
    obj, obj_prev = _object(t, width), _object(max(t - 1, 0), width)
    inside = (x >= obj[0]) & (x < obj[0] + size) & (y >= obj[1]) & (y < obj[1] + size)
    bg = _texture(x + cam[0], y + cam[1], 0.0)
    fg = _texture((x - obj[0]) * 3.0, (y - obj[1]) * 3.0, 1.3)[..., ::-1] * np.float32(1.2)
    col = np.where(inside[..., None], fg, bg)
    z = np.where(inside, OBJECT_Z, BACKGROUND_Z).astype(np.float32)
    mv_bg = cam - cam_prev
    mv_obj = obj_prev - obj
    mv = np.where(inside[..., None], mv_obj, mv_bg).astype(np.float32)
    return col, z, mv


def write_synthetic_sequence(
    out_dir: str | Path,
    lr_size: tuple[int, int] = (32, 24),
    scale: int = 2,
    frames: int = 8,
    pattern: str = "grid",
    cut_at: int | None = None,
    name: str = "synthetic",
) -> Path:
    """Write a sequence to ``out_dir``; returns it.  Sizes are ``(width, height)``."""
    out = Path(out_dir)
    lw, lh = lr_size
    hw, hh = lw * scale, lh * scale
    jit = jitter_sequence(pattern, scale, frames)
    size = max(6, hw // 4)
    ss = 4  # reference samples per axis per HR pixel
    for t in range(frames):
        jx, jy = jit[t]
        ly, lx = np.meshgrid(np.arange(lh) + 0.5 + jy, np.arange(lw) + 0.5 + jx, indexing="ij")
        col, _, _ = _shade(lx * scale, ly * scale, t, size, hw, cut_at)
        cy, cx = np.meshgrid(np.arange(lh) + 0.5, np.arange(lw) + 0.5, indexing="ij")
        _, z, mv = _shade(cx * scale, cy * scale, t, size, hw, cut_at)
        write_buffer(out, "lr", "color", t, col)
        write_buffer(out, "lr", "depth", t, z[..., None])
        write_buffer(out, "lr", "motion", t, mv / scale)
        acc = np.zeros((hh, hw, 3), dtype=np.float64)
        for k in range(ss * ss):
            oy, ox = (k // ss + 0.5) / ss, (k % ss + 0.5) / ss
            hy, hx = np.meshgrid(np.arange(hh) + oy, np.arange(hw) + ox, indexing="ij")
            acc += _shade(hx, hy, t, size, hw, cut_at)[0]
        write_buffer(out, "hr", "reference", t, (acc / (ss * ss)).astype(np.float32))
        hy, hx = np.meshgrid(np.arange(hh) + 0.5, np.arange(hw) + 0.5, indexing="ij")
        _, hz, hmv = _shade(hx, hy, t, size, hw, cut_at)
        write_buffer(out, "hr", "depth", t, hz[..., None])
        write_buffer(out, "hr", "motion", t, hmv)
    meta = SequenceMeta(
        format=FORMAT_NAME,
        version=FORMAT_VERSION,
        name=name,
        scale=scale,
        lr_size=(lw, lh),
        hr_size=(hw, hh),
        jitter_pattern=pattern,
        frames=[FrameMeta(index=t, jitter=(float(jit[t][0]), float(jit[t][1])), reset=(t == 0 or t == cut_at), time=t / 30.0) for t in range(frames)],
        near=NEAR,
        far=FAR,
        depth_encoding="linear",
        buffers={"lr": ["color", "depth", "motion"], "hr": ["reference", "depth", "motion"]},
        scene={"generator": "mnss_kit.dataset.synthetic", "cut_at": cut_at},
    )
    write_meta(out, meta)
    return out
