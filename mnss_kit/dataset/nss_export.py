"""Write toolkit sequences as an Arm NSS capture (the layout ``mnss-kit data import nss`` reads;
see ``importers/nss.py``), so the toolkit's renderer can stand in for an engine's capture plugin.

The buffers are written in the NSS types (half colour and motion in UV, float depth) and the
metadata as the spec lists it.  Only sequences the renderer writes are accepted: hardware forward
depth, motion in pixels to the previous frame with +y down, linear HDR colour.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..fileio import atomic_directory
from .exr import write_exr
from .format import MotionConvention, SequenceMeta, read_meta, read_raw_buffer

NSS_VERSION = "1.0.1"
RENDERER_MOTION = MotionConvention(units="pixels", points_to="previous", y_axis="down", scale=1.0)
# NSS stores motion as half floats.  A point that barely stayed in front of the previous camera can
# move by more than half's range (in UV units); it is clamped to the largest half, still far off-screen.
HALF_MAX = float(np.finfo(np.float16).max)


def export_nss(seq_dirs: list[Path], out: str | Path, overwrite: bool = False, progress=None) -> list[str]:
    """Write ``seq_dirs`` as one NSS capture at ``out`` (atomically), named ``0000``, ``0001``, ...
    in the given order; returns those names.  ``progress(name)`` is called after each sequence."""
    names = [f"{k:04d}" for k in range(len(seq_dirs))]
    with atomic_directory(out, overwrite=overwrite) as staging:
        for seq_dir, name in zip(seq_dirs, names):
            write_nss_sequence(Path(seq_dir), staging, name)
            if progress:
                progress(name)
    return names


def write_nss_sequence(seq_dir: Path, root: Path, sequence: str = "0000") -> None:
    """Write the toolkit sequence ``seq_dir`` into the NSS capture ``root`` as ``sequence``, ratio x{scale}."""
    meta = read_meta(seq_dir)
    _check_exportable(seq_dir, meta)
    ratio = nss_ratio(meta.scale)
    for i in range(meta.frame_count):
        def put(key, image, half=True, channels=("R", "G")):
            write_exr(root / key / sequence / f"{i:04d}.exr", image, half=half, channels=channels)

        def rgba(res, buffer):
            rgb = read_raw_buffer(seq_dir, res, buffer, i)
            return np.concatenate([rgb, np.ones_like(rgb[..., :1])], axis=-1)

        put("ground_truth", rgba("hr", "reference"), channels=tuple("RGBA"))
        put("motion_gt", _uv_motion(read_raw_buffer(seq_dir, "hr", "motion", i), meta.hr_size))
        put(f"{ratio}/color", rgba("lr", "color"), channels=tuple("RGBA"))
        put(f"{ratio}/depth", read_raw_buffer(seq_dir, "lr", "depth", i), half=False, channels=("R",))
        put(f"{ratio}/motion", _uv_motion(read_raw_buffer(seq_dir, "lr", "motion", i), meta.lr_size))
    (root / f"{sequence}.json").write_text(json.dumps(sequence_json(meta)))


def nss_ratio(scale) -> str:
    """The NSS ratio folder of a scale: ``x2``, ``x1_5`` (the capture spec writes the point as ``_``)."""
    return "x" + (str(int(scale)) if float(scale).is_integer() else f"{float(scale):g}".replace(".", "_"))


def _uv_motion(pixels: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``(H, W, 2)`` motion in pixels -> UV units within the half-float range."""
    return np.clip(pixels / np.float32(size), -HALF_MAX, HALF_MAX)


def sequence_json(meta: SequenceMeta) -> dict:
    """The NSS per-sequence metadata of ``meta`` (one entry per frame)."""
    lw, lh = meta.lr_size
    frames = [{
        "Frame": i, "FovX": 1.0, "FovY": 0.6, "CameraNearPlane": meta.near, "CameraFarPlane": meta.far,
        # column-major storage of the row-vector matrix (P V)^T: the row-major listing of P V
        "ViewProjection": [float(v) for v in (np.array(f.proj).reshape(4, 4) @ np.array(f.view).reshape(4, 4)).ravel()],
        "Jitter": {"X": f.jitter[0], "Y": f.jitter[1]},
        "NormalizedPerRatioJitter": [{"X": f.jitter[0] / lw, "Y": f.jitter[1] / lh}],
        "Exposure": meta.exposure, "CameraCut": bool(f.reset and i > 0),
    } for i, f in enumerate(meta.frames)]
    return {
        "Version": NSS_VERSION, "EmulatedFramerate": 30, "TargetResolution": {"X": meta.hr_size[0], "Y": meta.hr_size[1]},
        "Samples": {"Sequence": meta.jitter_pattern, "Count": 12, "Quantized": True}, "ReverseZ": False,
        "UpscalingRatiosIndices": {f"{nss_ratio(meta.scale)}_index": 0}, "Frames": frames,
    }


def _check_exportable(seq_dir: Path, meta: SequenceMeta) -> None:
    found = {"depth": (meta.depth_encoding, meta.reverse_z), "motion": meta.motion, "colour": meta.color_space}
    wanted = {"depth": ("hardware", False), "motion": RENDERER_MOTION, "colour": "linear_hdr"}
    for key in found:
        if found[key] != wanted[key]:
            raise UserError(f"{seq_dir}: {key} convention {found[key]} cannot be written as an NSS capture "
                            f"(the exporter takes the renderer's: {wanted[key]})")
