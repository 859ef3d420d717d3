"""Atomic writes: a reader never sees a half-written file or directory.

Every temporary name is hidden (a leading dot) and carries the writing
process's id: ``.NAME.staging.PID.XXXXXXXX`` (a directory), ``.NAME.old.PID.XXXXXXXX``
(a replaced directory on its way out) and ``.NAME.tmp.PID.XXXXXXXX[SUFFIX]`` (a file).
A run that is killed cannot remove its own; the next run that writes the same
output removes those whose process is gone (:func:`remove_stale_leftovers`),
and leaves alone those of a run still going on.

JSON files hold no NaN or infinity (JSON has neither): ``json_safe`` writes them as ``null``.  An
infinite PSNR (identical images, ``metrics.psnr``) is therefore ``null`` in every JSON report.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import logging
import math
import os
import re
import shutil
import tempfile
import time
from pathlib import Path
from typing import Iterator

import numpy as np

from .errors import UserError

HASH_CHUNK = 1 << 20

log = logging.getLogger(__name__)

OUTPUT_KINDS = ("file", "directory", "into")  # see check_output
LEGACY_STALE_SECONDS = 600  # a leftover named without a process id (older releases) this old is a killed run's
# the filesystem, not the program, failed the write: reported as a UserError naming the output
_WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG}


def check_output(path: str | os.PathLike, kind: str = "file") -> Path:
    """Check, before any work, that ``path`` can be written; a UserError names the path and the reason.

    ``kind``: ``"file"`` (replaced atomically: a temporary file beside it),
    ``"directory"`` (replaced atomically: a staging directory beside it), or
    ``"into"`` (a directory the command writes files into).  Walks up to the
    first existing ancestor, which must be a writable directory, proven by
    creating and removing a file there.  Also removes what killed runs left
    of the same output (:func:`remove_stale_leftovers`).
    """
    if kind not in OUTPUT_KINDS:
        raise ValueError(f"kind must be one of {OUTPUT_KINDS}, got {kind!r}")
    path = Path(os.path.abspath(path))
    if path.is_dir() and kind == "file":
        raise UserError(f"cannot write {path}: it is a directory")
    if path.exists() and not path.is_dir() and kind != "file":
        raise UserError(f"cannot write {path}: it exists and is not a directory")
    _require_writable(path, path if kind == "into" and path.is_dir() else path.parent)
    remove_stale_leftovers(path)
    return path


def _require_writable(target: Path, where: Path) -> None:
    ancestor = where
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise UserError(f"cannot write {target}: {ancestor} is a file, not a directory")
    try:  # a real write: permission bits alone miss a read-only mount, and root ignores them
        with tempfile.TemporaryFile(dir=ancestor, prefix=".mnss-write-test."):
            pass
    except OSError as e:
        raise UserError(f"cannot write {target}: {ancestor} is not writable ({e.strerror})") from None
    if not os.access(ancestor, os.W_OK | os.X_OK):  # e.g. a directory other users may not write
        raise UserError(f"cannot write {target}: {ancestor} is not writable (permission denied)")


def _write_error(path: Path, e: OSError) -> UserError:
    return UserError(f"cannot write {path}: {e.strerror or e}")


def _temp_prefix(path: Path, kind: str) -> str:
    return f".{path.name}.{kind}.{os.getpid()}."


def _leftover_pattern(path: Path) -> re.Pattern:
    """Temporary names of ``path``; group ``pid`` is None for the names of older releases (no process id)."""
    name, rand = re.escape(path.name), "[a-z0-9_]{8}"  # tempfile's random part
    ends = r"\.tmp" + (f"|{re.escape(path.suffix)}" if path.suffix else "")
    return re.compile(rf"^\.{name}\.(?:(?:staging|old|tmp)\.(?P<pid>\d+)\.{rand}(?:{ends})?"
                      rf"|(?:staging|old)\.{rand}|{rand}(?:{ends}))$")


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    return True


def remove_stale_leftovers(path: str | os.PathLike) -> list[Path]:
    """Remove the temporary files and staging directories that killed runs left beside ``path``.

    Only the toolkit's own temporary names for ``path`` are touched, and only
    those whose process is no longer running (a concurrent run's are kept);
    names without a process id count as stale once older than
    ``LEGACY_STALE_SECONDS``.  Says what it removed in one log line.
    """
    path = Path(os.path.abspath(path))
    pattern = _leftover_pattern(path)
    removed = []
    with contextlib.suppress(OSError):
        entries = [e for e in os.scandir(path.parent) if e.name.startswith(f".{path.name}.")]
        now = time.time()
        for entry in entries:
            m = pattern.match(entry.name)
            if not m or not _is_stale(m.group("pid"), entry, now):
                continue
            leftover = Path(entry.path)
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(leftover, ignore_errors=True)
            else:
                with contextlib.suppress(OSError):
                    leftover.unlink()
            removed.append(leftover)
    if removed:
        log.info("removed %d leftover(s) of killed runs beside %s: %s", len(removed), path,
                 ", ".join(p.name for p in removed))
    return removed


def _is_stale(pid: str | None, entry: os.DirEntry, now: float) -> bool:
    if pid is not None:
        return not _process_alive(int(pid))
    try:
        return now - entry.stat(follow_symlinks=False).st_mtime > LEGACY_STALE_SECONDS
    except OSError:
        return False


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
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=_temp_prefix(path, "tmp"))
    except OSError as e:
        raise _write_error(path, e) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as e:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(e, OSError):
            raise _write_error(path, e) from None
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


def file_lock(path: str | os.PathLike, waiting: str | None = None) -> contextlib.AbstractContextManager:
    """An exclusive lock on ``path`` (created if missing) held for a ``with`` block; the system
    releases it if the process dies.  ``waiting`` is logged when another process holds it.  The
    file is opened here, so a place that cannot hold it fails (OSError) before the block."""
    return _held(open(path, "a"), waiting)


@contextlib.contextmanager
def _held(handle, waiting: str | None) -> Iterator[None]:
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if waiting:
                log.info("%s", waiting)
            fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@contextlib.contextmanager
def atomic_output_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path for a writer that insists on a file name (torch.save, onnx.save).

    The file appears at ``path`` only if the block finishes without an exception.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=_temp_prefix(path, "tmp"), suffix=path.suffix)
        os.close(fd)
    except OSError as e:
        raise _write_error(path, e) from None
    try:
        with _filesystem_errors(path):
            yield Path(tmp)
            os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


@contextlib.contextmanager
def _filesystem_errors(path: Path) -> Iterator[None]:
    """A write that the filesystem refused (disk full, read-only) as a UserError naming ``path``."""
    try:
        yield
    except shutil.Error as e:  # copytree gathers its per-file errors as (src, dst, reason) text
        refused = [why for *_, why in _copy_errors(e) if refused_write(why)]
        if refused:
            raise UserError(f"cannot write {path}: {refused[0]}") from None
        raise
    except OSError as e:
        if e.errno in _WRITE_ERRNOS:
            raise _write_error(path, e) from None
        raise


def refused_write(text: str) -> str | None:
    """The reason a library's error ``text`` gives when the filesystem refused a write (disk full,
    quota, read-only, file too large), for libraries that report it as text, not as an OSError."""
    return next((os.strerror(n) for n in sorted(_WRITE_ERRNOS) if os.strerror(n) in text), None)


def _copy_errors(e: shutil.Error) -> list[tuple]:
    errors = e.args[0] if e.args else []
    return [tuple(str(x) for x in item) for item in errors if isinstance(item, tuple)] if isinstance(errors, list) else []


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike, overwrite: bool = False, merge: bool = False) -> Iterator[Path]:
    """Yield a staging directory that replaces ``path`` only when the block succeeds.

    On failure the staging directory is removed and ``path`` is left as it was,
    so a failed command leaves nothing partial in its output directory.  With
    ``merge`` the staged files are moved into ``path`` one by one instead,
    replacing files of the same name and keeping the others (for a directory
    the user may share with other files).
    """
    path = Path(os.path.abspath(path))
    if path.exists() and not path.is_dir():
        raise UserError(f"cannot write {path}: it exists and is not a directory")
    if not merge and path.exists() and any(path.iterdir()) and not overwrite:
        raise UserError(f"output directory {path} exists and is not empty (use --overwrite)")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(dir=path.parent, prefix=_temp_prefix(path, "staging")))
    except OSError as e:
        raise _write_error(path, e) from None
    try:
        with _filesystem_errors(path):
            yield staging
            _publish(staging, path, merge)
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)


def _publish(staging: Path, path: Path, merge: bool) -> None:
    try:
        if merge:
            path.mkdir(parents=True, exist_ok=True)
            for item in sorted(staging.iterdir()):
                os.replace(item, path / item.name)
        elif path.exists():
            backup = Path(tempfile.mkdtemp(dir=path.parent, prefix=_temp_prefix(path, "old")))
            os.replace(path, backup / "old")
            os.replace(staging, path)
            shutil.rmtree(backup, ignore_errors=True)
        else:
            os.replace(staging, path)
    except OSError as e:
        raise _write_error(path, e) from None


def portable_path(path: str | os.PathLike) -> str:
    """How reports and generated docs name a file or directory: relative to the working directory
    when it is inside it, else its last two components (``data/test_x2``), so nothing they write
    names the machine they were made on."""
    path = Path(os.path.abspath(path))
    try:
        return path.relative_to(Path.cwd()).as_posix()
    except ValueError:
        return Path(*path.parts[-2:]).as_posix() if len(path.parts) > 2 else path.name


def portable_command(argv: list[str]) -> str:
    """``argv`` joined for a report, absolute paths in it written as :func:`portable_path` does."""
    return " ".join(portable_path(a) if os.path.isabs(a) else a for a in argv)
