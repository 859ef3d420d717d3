"""OpenEXR read/write for dataset buffers (through the official OpenEXR bindings)."""

from __future__ import annotations

import contextlib
import functools
import io
import os
import sys
import threading
from pathlib import Path

import numpy as np
import OpenEXR

from ..errors import UserError
from ..fileio import atomic_output_path, refused_write

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
        try:
            with OpenEXR.File(header, chans) as f:
                f.write(str(tmp))
        except RuntimeError as e:  # the bindings report a full disk as text ("Failed to write pixel data ...")
            reason = refused_write(str(e))
            if reason:
                raise UserError(f"cannot write {path}: {reason}") from None
            raise
    return path


def read_exr(path: str | os.PathLike, channels: tuple[str, ...] | None = None) -> np.ndarray:
    """Read an EXR into ``(H, W, C)`` float32; ``channels`` picks and orders channels."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"missing file: {path}")
    refuse_lfs_pointer(path)
    try:
        with _quiet_stderr(), OpenEXR.File(str(path), separate_channels=True) as f:
            chans = {k: v.pixels for k, v in f.channels().items()}
    except Exception as e:  # the bindings raise plain exceptions for corrupt files
        first = (str(e).splitlines() or [type(e).__name__])[0]
        raise UserError(f"cannot read {path}: not a valid OpenEXR file ({first[:120]})") from None
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


LFS_POINTER_PREFIX = b"version https://git-lfs"
LFS_POINTER_MAX_BYTES = 1024  # a pointer is three short text lines (about 130 bytes)


def refuse_lfs_pointer(path: Path) -> None:
    """``UserError`` if ``path`` is a Git LFS pointer checked out in place of the image (a repository
    cloned without LFS): a reader would call it corrupt, which sends the user looking elsewhere."""
    if path.stat().st_size > LFS_POINTER_MAX_BYTES:
        return
    with open(path, "rb") as f:
        if f.read(len(LFS_POINTER_PREFIX)) == LFS_POINTER_PREFIX:
            raise UserError(f"{path}: a Git LFS pointer, not the image (fetch the files with `git lfs pull` "
                            "in the repository they came from)")


_quiet = {"lock": threading.Lock(), "depth": 0, "saved": None, "streams": None}  # shared by threads reading at once


@contextlib.contextmanager
def _quiet_stderr():
    """Output silenced for the block: on a corrupt file the OpenEXR library writes its own messages
    (the C++ core to fd 2, the bindings a warning through Python's ``sys.stdout``) ahead of the one
    line the toolkit reports.  File descriptors 1 and 2 point at /dev/null and ``sys.stdout`` /
    ``sys.stderr`` at a discarding buffer; C's buffers are flushed before the descriptors come back,
    so nothing surfaces later.  Reference-counted: the first reader redirects, the last one
    restores, so threads reading together never restore /dev/null."""
    with _quiet["lock"]:
        if _quiet["depth"] == 0:
            _quiet["saved"] = _redirect_to_null()
            _quiet["streams"] = sys.stdout, sys.stderr
            sys.stdout = sys.stderr = io.StringIO()
        _quiet["depth"] += 1
    try:
        yield
    finally:
        with _quiet["lock"]:
            _quiet["depth"] -= 1
            if _quiet["depth"] == 0:
                sys.stdout, sys.stderr = _quiet["streams"]
                _restore_descriptors(_quiet["saved"])
                _quiet["saved"] = _quiet["streams"] = None


def _restore_descriptors(saved: list[int] | None) -> None:
    if not saved:
        return
    _flush_c_streams()
    for fd, copy in zip((1, 2), saved):
        os.dup2(copy, fd)
        os.close(copy)


def _redirect_to_null() -> list[int] | None:
    """Copies of fd 1 and 2, which now point at /dev/null (None where they cannot be duplicated)."""
    try:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = [os.dup(1), os.dup(2)]
    except (OSError, ValueError, AttributeError):  # no usable descriptors (embedded interpreter)
        return None
    with open(os.devnull, "wb") as null:
        os.dup2(null.fileno(), 1)
        os.dup2(null.fileno(), 2)
    return saved


@functools.lru_cache(maxsize=1)
def _libc():
    import ctypes

    try:
        return ctypes.CDLL(None)
    except OSError:
        return None


def _flush_c_streams() -> None:
    """``fflush(NULL)``: C stdio output (C++'s cout goes through it) is written while fd 1 and 2 still point at /dev/null."""
    libc = _libc()
    if libc is not None and hasattr(libc, "fflush"):
        libc.fflush(None)
