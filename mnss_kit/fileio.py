"""Atomic writes (a reader never sees a half-written file or directory), and file hashes.

JSON files hold no NaN or infinity (JSON has neither): ``json_safe`` writes them as ``null``.  An
infinite PSNR (identical images, ``metrics.psnr``) is therefore ``null`` in every JSON report.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

import numpy as np

from .errors import UserError

HASH_CHUNK = 1 << 20


def sha256_file(path: str | os.PathLike) -> str:
    """Hex SHA-256 of a file, read in chunks."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(HASH_CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same directory and rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    return path


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def read_json(path: str | os.PathLike):
    """The parsed JSON file ``path``; ``UserError`` naming the file when it is not valid JSON."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise UserError(f"{path}: not valid JSON ({e})") from None


def check_format(data, path, name: str, version_key: str, newest: int, what: str, newer=UserError) -> int:
    """The version of a JSON document that must hold ``"format": name`` and an integer ``version_key``.

    ``UserError`` naming ``path`` for another format (``what`` says what the file should be, e.g.
    "a tensor dump") or a version that is not a positive integer; ``newer`` (an exception class)
    for a version above ``newest``: a reader refuses what a newer mnss-kit wrote instead of guessing.
    """
    if not isinstance(data, dict) or data.get("format") != name:
        raise UserError(f"{path}: not {what} (format is not '{name}')")
    version = data.get(version_key)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise UserError(f"{path}: {version_key} must be a positive integer, got {version!r}")
    if version > newest:
        raise newer(f"{path}: format version {version} is newer than this mnss-kit reads (up to {newest}); "
                    f"upgrade mnss-kit to read it")
    return version


def json_safe(obj):
    """A copy of ``obj`` that JSON can hold: NaN and infinities to None, numpy scalars to Python."""
    if isinstance(obj, dict):
        return {(k.item() if isinstance(k, np.generic) else k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def json_text(obj) -> str:
    """``obj`` as the toolkit writes JSON files: ``json_safe``, indented by 2, a final newline."""
    return json.dumps(json_safe(obj), indent=2, allow_nan=False) + "\n"


def atomic_write_json(path: str | os.PathLike, obj) -> Path:
    return atomic_write_text(path, json_text(obj))


@contextlib.contextmanager
def atomic_output_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path for a writer that insists on a file name (torch.save, onnx.save).

    The file appears at ``path`` only if the block finishes without an exception.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike, overwrite: bool = False) -> Iterator[Path]:
    """Yield a staging directory that replaces ``path`` only when the block succeeds.

    On failure the staging directory is removed and ``path`` is left as it was,
    so a failed command leaves nothing partial in its output directory.
    """
    path = Path(path)
    if path.exists() and any(path.iterdir()) and not overwrite:
        raise UserError(f"output directory {path} exists and is not empty (use --overwrite)")
    path.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.staging."))
    try:
        yield staging
        if path.exists():
            backup = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.old."))
            os.replace(path, backup / "old")
            os.replace(staging, path)
            shutil.rmtree(backup, ignore_errors=True)
        else:
            os.replace(staging, path)
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
