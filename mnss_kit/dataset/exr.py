"""OpenEXR read/write for dataset buffers (through the official OpenEXR bindings)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import OpenEXR

from ..errors import UserError
from ..fileio import atomic_output_path

# channel names by channel count; depth uses "Z" (see dataset.format.BUFFERS)
CHANNEL_NAMES = {1: ("Y",), 2: ("R", "G"), 3: ("R", "G", "B"), 4: ("R", "G", "B", "A")}


def write_exr(path: str | os.PathLike, image: np.ndarray, half: bool = True, channels: tuple[str, ...] | None = None) -> Path:
    """Write ``(H, W, C)`` float data atomically; half float unless ``half=False``."""
    img = np.asarray(image)
    if img.ndim == 2:
        img = img[..., None]
    if img.ndim != 3:
        raise ValueError(f"write_exr expects (H, W, C), got shape {img.shape}")
    names = channels or CHANNEL_NAMES[img.shape[2]]
    dtype = np.float16 if half else np.float32
    chans = {n: np.ascontiguousarray(img[..., i].astype(dtype)) for i, n in enumerate(names)}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    path = Path(path)
    with atomic_output_path(path) as tmp:
        with OpenEXR.File(header, chans) as f:
            f.write(str(tmp))
    return path


def read_exr(path: str | os.PathLike, channels: tuple[str, ...] | None = None) -> np.ndarray:
    """Read an EXR into ``(H, W, C)`` float32; ``channels`` picks and orders channels."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"missing file: {path}")
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            chans = {k: v.pixels for k, v in f.channels().items()}
    except Exception as e:  # the bindings raise plain exceptions for corrupt files
        raise UserError(f"cannot read {path}: not a valid OpenEXR file ({str(e).splitlines()[0][:120]})") from None
    if channels is None:
        for names in (("R", "G", "B", "A"), ("R", "G", "B"), ("R", "G"), ("Z",), ("Y",)):
            if set(names) == set(chans):
                channels = names
                break
        else:
            channels = tuple(sorted(chans))
    missing = [c for c in channels if c not in chans]
    if missing:
        raise UserError(f"{path}: missing channel(s) {', '.join(missing)} (has {', '.join(sorted(chans))})")
    return np.stack([chans[c].astype(np.float32) for c in channels], axis=-1)
