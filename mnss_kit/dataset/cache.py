"""Decode each sequence once into memory-mappable ``.npy`` files, so training is not bound by EXR decoding.

Layout (one directory per sequence and dataset state)::

    CACHE/<sequence>-<path hash>/<key>/<res>_<buffer>.npy      (T, C, H, W)

The arrays hold canonical values (``format.read_buffer``): colour and the
G-buffers as float16, depth and motion as float32.  ``key`` hashes meta.json
and every frame file's name, size and modification time, so editing, adding or
re-exporting a file gives a new key and the stale directory is removed on the
next build.  Each ``.npy`` is written under a temporary name and renamed when
complete: a killed build leaves no file that could be mistaken for a cache, and
the next build removes its temporary file.  A file damaged later (truncated,
a bad header, another shape) is found by :meth:`SequenceCache.damage` and rebuilt.
Builds hold a lock on the cache directory, so two trainings started together
on the same data decode it once: the second waits and then finds it built.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
from pathlib import Path
from typing import Iterable

import numpy as np

from ..errors import UserError
from ..fileio import atomic_output_path, file_lock, remove_stale_leftovers
from .format import BUFFERS, META_FILE, SequenceMeta, buffer_path, find_sequences, read_buffer, read_meta

log = logging.getLogger(__name__)

CACHE_VERSION = 1
DEFAULT_CACHE_NAME = ".cache"
NPY_HEADER_READERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
FLOAT32_BUFFERS = ("depth", "motion")  # half float loses sub-pixel motion and far depth precision


def cache_dtype(buffer: str) -> np.dtype:
    return np.dtype(np.float32 if buffer in FLOAT32_BUFFERS else np.float16)


def default_cache_dir(dataset_root: str | Path) -> Path:
    return Path(dataset_root) / DEFAULT_CACHE_NAME


def frame_files(seq_dir: Path) -> list[tuple[str, os.stat_result]]:
    """Every frame file under ``lr/`` and ``hr/`` as (relative posix path, stat), sorted by path."""
    out = []
    for res in ("lr", "hr"):
        base = seq_dir / res
        if not base.is_dir():
            continue
        for root, dirs, files in os.walk(base):
            dirs[:] = sorted(d for d in dirs if not d.startswith("."))
            for name in files:
                if name.startswith("."):  # temporary files of an interrupted atomic write
                    continue
                path = Path(root) / name
                out.append((path.relative_to(seq_dir).as_posix(), path.stat()))
    return sorted(out)


def dataset_fingerprint(paths: str | Path | Iterable[str | Path]) -> str:
    """sha256 (hex) over each sequence's name, meta.json bytes, and frame file names and sizes.

    ``paths`` is a dataset root, a sequence directory, or several of them.  The
    value does not depend on where the data lives or on file times, so a copied
    dataset keeps its fingerprint; checkpoints record it.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    seqs = {s.resolve() for p in paths for s in find_sequences(p)}
    entries = sorted((s.name, (s / META_FILE).read_bytes(), s) for s in seqs)
    h = hashlib.sha256()
    for name, meta_bytes, seq in entries:
        h.update(f"sequence {name}\n".encode())
        h.update(hashlib.sha256(meta_bytes).digest())
        for rel, st in frame_files(seq):
            h.update(f"{rel} {st.st_size}\n".encode())
    return h.hexdigest()


def cache_key(seq_dir: Path) -> str:
    """Changes whenever meta.json or any frame file changes (content, size or modification time)."""
    h = hashlib.sha256(f"mnss-kit cache v{CACHE_VERSION}\n".encode())
    h.update(hashlib.sha256((seq_dir / META_FILE).read_bytes()).digest())
    for rel, st in frame_files(seq_dir):
        h.update(f"{rel} {st.st_size} {st.st_mtime_ns}\n".encode())
    return h.hexdigest()[:20]


class SequenceCache:
    """The cache entry of one sequence: where its arrays live and how to build them."""

    def __init__(self, seq_dir: str | Path, cache_root: str | Path, meta: SequenceMeta | None = None):
        self.seq_dir = Path(seq_dir)
        self.meta = meta if meta is not None else read_meta(self.seq_dir)
        self.key = cache_key(self.seq_dir)
        where = hashlib.sha256(str(self.seq_dir.resolve()).encode()).hexdigest()[:8]
        self.entry_dir = Path(cache_root) / f"{self.seq_dir.name}-{where}"
        self.dir = self.entry_dir / self.key

    def path(self, res: str, buffer: str) -> Path:
        return self.dir / f"{res}_{buffer}.npy"

    def missing(self, buffers: Iterable[tuple[str, str]], report: bool = True) -> list[tuple[str, str]]:
        """The buffers to (re)build: absent, or damaged (said in one log line each when ``report``)."""
        todo = []
        for r, b in buffers:
            if not self.path(r, b).is_file():
                todo.append((r, b))
            elif problem := self.damage(r, b):
                if report:
                    log.warning("cache file %s is damaged (%s); rebuilding it", self.path(r, b), problem)
                todo.append((r, b))
        return todo

    def damage(self, res: str, buffer: str) -> str | None:
        """What is wrong with an existing cache file (header, shape, dtype, size), or None."""
        path = self.path(res, buffer)
        try:
            with open(path, "rb") as f:
                version = np.lib.format.read_magic(f)
                read_header = NPY_HEADER_READERS.get(version)
                if read_header is None:
                    return f"unknown .npy format version {version}"
                shape, fortran, dtype = read_header(f)
                offset = f.tell()
            size = path.stat().st_size
        except (OSError, ValueError, SyntaxError) as e:
            return f"unreadable header: {e}"
        if fortran or tuple(shape) != self.shape(res, buffer) or dtype != cache_dtype(buffer):
            return f"holds {dtype} {tuple(shape)}, expected {cache_dtype(buffer)} {self.shape(res, buffer)}"
        expected = offset + int(np.prod(shape)) * dtype.itemsize
        if size != expected:
            return f"{size} bytes, expected {expected}"
        return None

    def shape(self, res: str, buffer: str) -> tuple[int, int, int, int]:
        w, h = self.meta.lr_size if res == "lr" else self.meta.hr_size
        return (self.meta.frame_count, len(BUFFERS[res][buffer].channels), h, w)

    def open(self, res: str, buffer: str) -> np.ndarray:
        """Read-only memory map ``(T, C, H, W)`` (float16 or float32, see ``cache_dtype``)."""
        arr = np.load(self.path(res, buffer), mmap_mode="r")
        if arr.shape != self.shape(res, buffer) or arr.dtype != cache_dtype(buffer):
            raise UserError(f"cache file {self.path(res, buffer)} does not match its sequence; delete the cache directory")
        return arr

    def build(self, res: str, buffer: str, on_frame=None) -> Path:
        """Decode every frame of one buffer into ``path(res, buffer)``; NaN/Inf values are UserErrors."""
        self.dir.mkdir(parents=True, exist_ok=True)
        target = self.path(res, buffer)
        self._remove_stale(target)
        with atomic_output_path(target) as tmp:
            arr = np.lib.format.open_memmap(tmp, mode="w+", dtype=cache_dtype(buffer), shape=self.shape(res, buffer))
            for t, frame in enumerate(self.meta.frames):
                image = read_buffer(self.seq_dir, self.meta, res, buffer, frame.index)
                require_finite(image, buffer_path(self.seq_dir, res, buffer, frame.index))
                arr[t] = image.transpose(2, 0, 1)
                if on_frame:
                    on_frame()
            arr.flush()
            del arr
        return target

    def _remove_stale(self, target: Path) -> None:
        """Drop directories of older keys and the temporary files killed builds left of ``target``."""
        for other in self.entry_dir.iterdir():
            if other.is_dir() and other.name != self.key:
                shutil.rmtree(other, ignore_errors=True)
        remove_stale_leftovers(target)


def require_finite(image: np.ndarray, path: Path) -> None:
    bad = ~np.isfinite(image)
    if bad.any():
        y, x = np.argwhere(bad.any(axis=-1))[0]
        raise UserError(f"{path}: {int(bad.sum())} NaN/Inf value(s), first at x={x} y={y} (see 'mnss-kit data check')")


def prepare_caches(
    seq_dirs: Iterable[str | Path],
    buffers: Iterable[tuple[str, str]],
    cache_root: str | Path,
    progress: bool = True,
    metas: Iterable[SequenceMeta] | None = None,
) -> list[SequenceCache]:
    """Return the cache entry of every sequence, building the missing ``(res, buffer)`` arrays first."""
    seq_dirs = [Path(s) for s in seq_dirs]
    buffers = list(buffers)
    cache_root = Path(cache_root)
    try:
        cache_root.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"cannot create cache directory {cache_root} ({e.strerror}); choose another with --cache-dir") from None
    metas = list(metas) if metas is not None else [None] * len(seq_dirs)
    caches = [SequenceCache(s, cache_root, m) for s, m in zip(seq_dirs, metas)]
    if not any(c.missing(buffers, report=False) for c in caches):
        return caches
    with _build_lock(cache_root):  # another process may have built them while this one waited
        todo = [(c, r, b) for c in caches for r, b in c.missing(buffers)]
        if todo:
            from .check import require_clean  # what data check calls an error is not cached (nor trained on)

            for seq_dir in dict.fromkeys(c.seq_dir for c, _, _ in todo):
                require_clean(seq_dir)
            _build(todo, cache_root, progress)
    return caches


def _build_lock(cache_root: Path):
    """An exclusive lock on ``cache_root`` for the duration of a build (released if the process dies)."""
    try:
        return file_lock(cache_root / ".build.lock", f"waiting for another process building the dataset cache in {cache_root}")
    except OSError as e:
        raise UserError(f"cannot write the dataset cache in {cache_root} ({e.strerror}); choose another with --cache-dir") from None


def _build(todo: list[tuple[SequenceCache, str, str]], cache_root: Path, progress: bool) -> None:
    from tqdm import tqdm

    total = sum(c.meta.frame_count for c, _, _ in todo)
    log.info("building the dataset cache in %s (%d buffers, %d frames)", cache_root, len(todo), total)
    with tqdm(total=total, desc="caching dataset", unit="frame", disable=None if progress else True) as bar:
        for cache, res, buffer in todo:
            bar.set_postfix_str(f"{cache.seq_dir.name} {res}/{buffer}")
            try:
                cache.build(res, buffer, on_frame=lambda: bar.update(1))
            except OSError as e:  # read-only dataset directory, disk full
                raise UserError(f"cannot write the dataset cache in {cache_root} ({e.strerror}); choose another with --cache-dir") from None
