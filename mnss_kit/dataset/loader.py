"""PyTorch loading: recurrent training windows with scale-aligned crops, and whole sequences for evaluation.

A window of ``T`` consecutive frames of one sequence is a dict of float32
tensors (``docs/architecture.md``)::

    color (T, 3, h, w)   depth (T, 1, h, w)   motion (T, 2, h, w)   LR, canonical conventions
    jitter (T, 2)        reset (T,)                                  LR pixels; 1.0 = no history
    reference (T, 3, H, W)                                           HR target, display values
                                      (hr/reference, or the buffer ``reference`` names, e.g. reference_taa)
    hr_<buffer> (T, C, H, W), lr_<buffer> (T, C, h, w)               optional G-buffers
    scale (T,)                                                       only with ``with_scale``: the nominal scale

Crops sit at integer LR pixels, and the HR crop is the same screen area
(offset and size times the scale), so the jitter offsets stay valid.  At a
fractional scale (``ops.scale``) an axis maps LR to HR by its exact ratio
``hr / lr = p / q``: an LR offset or size is a whole number of HR pixels only
at multiples of ``q`` (2 for 72/48 = 3/2), so crop offsets are drawn on that
grid and crop sizes must be multiples of it (a UserError names the step).  An
axis whose ratio does not reduce (1280/753) takes whole-frame crops only.

Several scales (``mixed_scales=True``, training one model at several quality
modes): each sequence's ratio must be exactly its scale on both axes (648x360
-> 432x240 at 1.5), so every crop on the grid of the scale's denominator ``q``
maps to ``crop * s`` HR pixels exactly; the LR crop of each scale is the
requested one rounded down to a multiple of ``q`` (32 -> 32 at 1.5 (HR 48),
30 at 1.7 (HR 51), 32 at 2 and 3), and ``window_groups`` lists the windows
of each scale, so a batch drawn from one group stacks.  Windows then carry
``scale`` (T,), the sequence's nominal scale, the model's frame key.  Values
come from ``format.read_buffer`` (canonical conventions), either straight from
the EXR files or from the decoded cache (``cache.py``; colour then carries
float16 rounding, below 2.5e-4 for display values).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import torch
from torch.utils.data import Dataset

from ..errors import UserError
from ..ops import scale as scales
from .cache import SequenceCache, dataset_fingerprint, default_cache_dir, prepare_caches, require_finite
from .format import META_FILE, REQUIRED_BUFFERS, SequenceMeta, buffer_path, find_sequences, read_buffer, read_meta

log = logging.getLogger(__name__)

# window key -> (resolution, buffer) for the buffers every window carries
BASE_KEYS = {"color": ("lr", "color"), "depth": ("lr", "depth"), "motion": ("lr", "motion"), "reference": ("hr", "reference")}


@dataclass(frozen=True)
class Crop:
    """A rectangle in pixels: left, top, width, height."""

    x: int
    y: int
    width: int
    height: int

    def scaled(self, scale: int) -> Crop:
        return Crop(self.x * scale, self.y * scale, self.width * scale, self.height * scale)

    def mapped(self, ratios) -> Crop:
        """The same screen area at exact per-axis ratios ``(hr / lr)`` (``SequenceMeta.ratios``); a
        UserError unless every edge lands on a whole HR pixel (``ops.scale.crop_step``)."""
        rx, ry = ratios
        return Crop(scales.lr_to_hr(self.x, rx, "crop offset"), scales.lr_to_hr(self.y, ry, "crop offset"),
                    scales.lr_to_hr(self.width, rx, "crop width"), scales.lr_to_hr(self.height, ry, "crop height"))


def hr_crop(lr_crop: Crop, meta: SequenceMeta) -> Crop:
    """The HR crop of ``lr_crop``: offset and size times the scale (an integer scale, as always), or
    times each axis's exact ratio (a fractional one)."""
    if isinstance(meta.scale, int):
        return lr_crop.scaled(meta.scale)
    return lr_crop.mapped(meta.ratios)


class ExrFrames:
    """Reads frames straight from the EXR files (decodes on every call)."""

    def __init__(self, seq_dir: Path, meta: SequenceMeta):
        self.seq_dir, self.meta = seq_dir, meta

    def read(self, res: str, buffer: str, start: int, count: int, crop: Crop) -> np.ndarray:
        """``(count, C, crop.height, crop.width)`` float32 of frames ``start .. start+count-1``."""
        out = []
        for frame in self.meta.frames[start : start + count]:
            image = read_buffer(self.seq_dir, self.meta, res, buffer, frame.index)
            require_finite(image, buffer_path(self.seq_dir, res, buffer, frame.index))
            out.append(image[crop.y : crop.y + crop.height, crop.x : crop.x + crop.width].transpose(2, 0, 1))
        return np.ascontiguousarray(np.stack(out), dtype=np.float32)


class CachedFrames:
    """Reads frames from the memory-mapped cache; maps are opened lazily in each worker process."""

    def __init__(self, cache: SequenceCache):
        self.cache = cache
        self._maps: dict[tuple[str, str], np.ndarray] = {}

    def __getstate__(self):  # a memmap would be pickled by value: send only the paths to workers
        return {"cache": self.cache, "_maps": {}}

    def read(self, res: str, buffer: str, start: int, count: int, crop: Crop) -> np.ndarray:
        key = (res, buffer)
        if key not in self._maps:
            self._maps[key] = self.cache.open(res, buffer)
        block = self._maps[key][start : start + count, :, crop.y : crop.y + crop.height, crop.x : crop.x + crop.width]
        return np.array(block, dtype=np.float32)  # a copy: memmap views are read-only


@dataclass
class LoadedSequence:
    seq_dir: Path
    meta: SequenceMeta
    source: ExrFrames | CachedFrames
    reference: str = "reference"  # the HR buffer loaded as the key ``reference``

    @property
    def name(self) -> str:
        return self.seq_dir.name

    def frames(self, start: int, count: int, lr_crop: Crop, extra_keys: dict[str, tuple[str, str]], reset_first: bool) -> dict[str, np.ndarray]:
        """Frames ``start .. start+count-1`` as float32 arrays with a leading time axis."""
        hr = hr_crop(lr_crop, self.meta)
        out = {}
        for key, (res, buffer) in {**BASE_KEYS, "reference": ("hr", self.reference), **extra_keys}.items():
            crop = lr_crop if res == "lr" else hr
            out[key] = self.source.read(res, buffer, start, count, crop)
        metas = self.meta.frames[start : start + count]
        out["jitter"] = np.array([f.jitter for f in metas], dtype=np.float32).reshape(count, 2)
        reset = np.array([f.reset for f in metas], dtype=np.float32)
        if start == 0 or reset_first:  # nothing before the first frame of a sequence or window
            reset[0] = 1.0
        out["reset"] = reset
        return out

    def full_frame(self) -> Crop:
        w, h = self.meta.lr_size
        return Crop(0, 0, w, h)


def extra_buffer_keys(hr_buffers: Iterable[str], lr_buffers: Iterable[str]) -> dict[str, tuple[str, str]]:
    """``{"hr_depth": ("hr", "depth"), ...}`` for the optional G-buffers; the base buffers are refused."""
    keys = {}
    for res, names in (("hr", hr_buffers), ("lr", lr_buffers)):
        for name in names:
            if name in REQUIRED_BUFFERS[res]:
                raise UserError(f"{res}/{name} is always loaded; do not request it as an extra buffer")
            keys[f"{res}_{name}"] = (res, name)
    return keys


def open_sequences(
    root: str | Path | Iterable[str | Path],
    extra_keys: dict[str, tuple[str, str]],
    cache: bool,
    cache_dir: str | Path | None,
    progress: bool = True,
    needed_by: str = "",
    reference: str = "reference",
) -> list[LoadedSequence]:
    """Every sequence under ``root`` (a dataset, a sequence, or a list of them), checked for the wanted buffers;
    ``needed_by`` names who wants the optional ones (e.g. ``the fusesr family``) in the error; ``reference``
    is the HR buffer loaded as the target (``reference``, ``reference_taa`` or ``reference_4x``)."""
    roots = [root] if isinstance(root, (str, Path)) else list(root)
    seq_dirs = [s for r in roots for s in find_sequences(r)]
    metas = [read_meta(s) for s in seq_dirs]
    base = {**BASE_KEYS, "reference": ("hr", reference)}
    wanted = list(dict.fromkeys([*base.values(), *extra_keys.values()]))
    for seq_dir, meta in zip(seq_dirs, metas):
        if not meta.frames:  # data check's error: training would skip the sequence without a word
            raise UserError(f"data check: {Path(seq_dir) / META_FILE}: no frames")
        for index, frame in enumerate(meta.frames):
            if frame.index != index:
                raise UserError(f"{seq_dir}: frame {index} in meta.json has index {frame.index}; frames must be 0, 1, 2, ... in order")
        for res, buffer in wanted:
            if buffer not in meta.buffers.get(res, []):
                who = f", which {needed_by} needs," if needed_by and (res, buffer) not in base.values() else ""
                raise UserError(f"{seq_dir}: buffer {res}/{buffer}{who} is not in this sequence (meta.json buffers.{res}; "
                                "docs/dataset.md lists each family's buffers)")
    if not cache:  # evaluation, calibration and golden frames read the files: data check's errors refuse them
        from .check import require_clean

        for seq_dir in seq_dirs:
            require_clean(seq_dir)
        return [LoadedSequence(s, m, ExrFrames(s, m), reference) for s, m in zip(seq_dirs, metas)]
    cache_root = Path(cache_dir) if cache_dir else default_cache_dir(roots[0])
    caches = prepare_caches(seq_dirs, wanted, cache_root, progress=progress, metas=metas)
    return [LoadedSequence(s, m, CachedFrames(c), reference) for s, m, c in zip(seq_dirs, metas, caches)]


class WindowDataset(Dataset):
    """Training windows of ``window`` consecutive frames, never spanning two sequences.

    ``crop`` is ``(width, height)`` in LR pixels (or ``None`` for full frames);
    its position is drawn per window from ``(seed, epoch, index)``, so it does
    not depend on the worker that loads it.  Call ``set_epoch`` before each
    epoch (with ``persistent_workers=False``) to draw new crops.  The dataset's
    ``reset`` flags are kept; ``window_starts_reset`` also sets reset on the
    first frame of every window, since the history before it is not available.
    """

    def __init__(
        self,
        root: str | Path | Iterable[str | Path],
        window: int,
        crop: tuple[int, int] | None = None,
        *,
        hr_buffers: Iterable[str] = (),
        lr_buffers: Iterable[str] = (),
        seed: int = 0,
        stride: int = 1,
        window_starts_reset: bool = True,
        cache: bool = True,
        cache_dir: str | Path | None = None,
        progress: bool = True,
        needed_by: str = "",
        augment: dict | None = None,
        mixed_scales: bool = False,
        with_scale: bool = False,
    ):
        """``mixed_scales``: sequences of several scales are grouped by scale (``window_groups``)
        instead of refused; ``with_scale``: every window carries ``scale`` (T,) float32."""
        if window < 1 or stride < 1:
            raise UserError(f"window and stride must be >= 1, got window={window} stride={stride}")
        self.window, self.seed, self.epoch = window, seed, 0
        self.augment = dict(augment or {})  # name -> probability per window (dataset.augment)
        self.window_starts_reset = window_starts_reset
        self.extra_keys = extra_buffer_keys(hr_buffers, lr_buffers)
        self.sequences = open_sequences(root, self.extra_keys, cache, cache_dir, progress, needed_by)
        self.with_scale = with_scale
        self.scales = sorted({s.meta.scale for s in self.sequences})
        if len(self.scales) != 1 and not mixed_scales:
            raise UserError(f"sequences have different scales {self.scales}; train one scale at a time")
        self.scale = self.scales[0] if len(self.scales) == 1 else None  # None: several (window_groups)
        if len(self.scales) == 1:
            self.crop_size = self._check_crop(crop)
            self.crop_sizes = {self.scale: self.crop_size}
        else:
            self.crop_sizes = self._mixed_crops(crop)
            self.crop_size = None if crop is None else self._check_crop(crop, check_grid=False)
        self.windows = [(i, start) for i, s in enumerate(self.sequences) for start in range(0, s.meta.frame_count - window + 1, stride)]
        for s in self.sequences:
            if s.meta.frame_count < window:
                log.warning("sequence %s has %d frames, fewer than the window of %d: skipped", s.name, s.meta.frame_count, window)
        if not self.windows:
            raise UserError(f"no sequence has the {window} frames a window needs")

    def _check_crop(self, crop: tuple[int, int] | None, check_grid: bool = True) -> tuple[int, int] | None:
        if crop is None:
            return None
        cw, ch = (int(crop), int(crop)) if np.isscalar(crop) else (int(crop[0]), int(crop[1]))
        for s in self.sequences:
            w, h = s.meta.lr_size
            if not (0 < cw <= w and 0 < ch <= h):
                raise UserError(f"crop {cw}x{ch} (LR pixels) does not fit sequence {s.name} of LR size {w}x{h}")
            if not check_grid:
                continue
            qx, qy = scales.crop_step(s.meta.lr_size, s.meta.hr_size)
            if (cw % qx and cw != w) or (ch % qy and ch != h):
                raise UserError(f"crop {cw}x{ch} (LR pixels) of sequence {s.name} (scale {s.meta.scale}, {w}x{h} -> "
                                f"{s.meta.hr_size[0]}x{s.meta.hr_size[1]}) does not map to whole HR pixels: at its "
                                f"ratio a crop is a multiple of {qx}x{qy} LR pixels (or the whole frame)")
        return cw, ch

    def _mixed_crops(self, crop) -> dict:
        """Per scale, the LR crop ``(w, h)`` (or None: full frames) of a dataset of several scales:
        each sequence's ratio must be exactly its scale, and the requested crop is rounded down to
        the grid of the scale's denominator."""
        for s in self.sequences:
            exact = scales.as_fraction(s.meta.scale)
            if scales.axis_ratios(s.meta.lr_size, s.meta.hr_size) != (exact, exact):
                (w, h), (hw, hh) = s.meta.lr_size, s.meta.hr_size
                raise UserError(f"sequence {s.name} is {w}x{h} -> {hw}x{hh}, not exactly x{s.meta.scale} on both axes: "
                                f"training on several scales needs sizes whose ratio is the scale (an hr_size divisible "
                                f"by {exact.num}, e.g. {_exact_size_hint(s.meta.hr_size, exact)})")
        if crop is None:
            return {scale: None for scale in self.scales}
        self._check_crop(crop, check_grid=False)  # fits every sequence
        cw, ch = (int(crop), int(crop)) if np.isscalar(crop) else (int(crop[0]), int(crop[1]))
        sizes = {}
        for scale in self.scales:
            q = scales.as_fraction(scale).den
            sizes[scale] = (max(q, cw - cw % q), max(q, ch - ch % q))
            frames = [s for s in self.sequences if s.meta.scale == scale]
            if any(sizes[scale][0] > s.meta.lr_size[0] or sizes[scale][1] > s.meta.lr_size[1] for s in frames):
                raise UserError(f"crop {cw}x{ch} (LR pixels) at x{scale} needs a multiple of {q}, which does not fit "
                                f"sequence {frames[0].name} of LR size {frames[0].meta.lr_size[0]}x{frames[0].meta.lr_size[1]}")
            log.info("x%s: LR crops %dx%d (HR %dx%d)", scale, *sizes[scale], *scales.hr_size_for(sizes[scale], scale))
        return sizes

    def window_groups(self) -> dict:
        """``{scale: [window index, ...]}`` in ascending scale: the windows a batch of one scale draws from."""
        groups = {scale: [] for scale in self.scales}
        for index, (seq, _) in enumerate(self.windows):
            groups[self.sequences[seq].meta.scale].append(index)
        return {scale: members for scale, members in groups.items() if members}

    def __len__(self) -> int:
        return len(self.windows)

    def set_epoch(self, epoch: int) -> None:
        self.epoch = int(epoch)

    def window_info(self, index: int) -> tuple[str, int]:
        """(sequence name, first frame) of window ``index``."""
        seq, start = self.windows[index]
        return self.sequences[seq].name, start

    def crop_for(self, index: int) -> Crop:
        """The LR crop of window ``index`` this epoch (the HR crop is ``hr_crop(crop, meta)``)."""
        seq = self.sequences[self.windows[index][0]]
        if self.crop_sizes[seq.meta.scale] is None:
            return seq.full_frame()
        cw, ch = self.crop_sizes[seq.meta.scale]
        w, h = seq.meta.lr_size
        rng = np.random.default_rng([self.seed, self.epoch, index])
        qx, qy = scales.crop_step(seq.meta.lr_size, seq.meta.hr_size)
        if qx == 1 and qy == 1:  # an integer scale (or a ratio that is exact per LR pixel): as always
            return Crop(int(rng.integers(0, w - cw + 1)), int(rng.integers(0, h - ch + 1)), cw, ch)
        # offsets on the grid of LR pixels that land on whole HR pixels (ops.scale.crop_step)
        return Crop(qx * int(rng.integers(0, (w - cw) // qx + 1)), qy * int(rng.integers(0, (h - ch) // qy + 1)), cw, ch)

    def __getitem__(self, index: int) -> dict[str, torch.Tensor]:
        seq, start = self.windows[index]
        arrays = self.sequences[seq].frames(start, self.window, self.crop_for(index), self.extra_keys, self.window_starts_reset)
        if self.augment:
            from .augment import augment_window

            rng = np.random.default_rng([self.seed, self.epoch, index, 1])  # 1: not the crop's stream
            arrays = augment_window(arrays, self.sequences[seq].meta, self.augment, rng)
        if self.with_scale:
            arrays["scale"] = np.full(self.window, float(self.sequences[seq].meta.scale), dtype=np.float32)
        return {k: torch.from_numpy(v) for k, v in arrays.items()}

    def fingerprint(self) -> str:
        return dataset_fingerprint([s.seq_dir for s in self.sequences])


def _exact_size_hint(hr_size, exact) -> str:
    """The nearest display size whose ratio is exactly ``exact`` (a reduced ``Ratio``), as text."""
    hr = [max(exact.num, round(v / exact.num) * exact.num) for v in hr_size]
    return f"{hr[0]}x{hr[1]} -> {hr[0] * exact.den // exact.num}x{hr[1] * exact.den // exact.num}"


class SequenceFrames:
    """One sequence, full frames, in order: each item is a frame dict with a leading batch axis of 1.

    The shapes are a window's with ``T = 1`` read as ``N = 1`` (``color``
    (1, 3, h, w), ``jitter`` (1, 2), ``reset`` (1,), ...), ready for
    ``model(frame, state)``.  Frame 0 always has reset set.
    """

    def __init__(self, sequence: LoadedSequence, extra_keys: dict[str, tuple[str, str]]):
        self.sequence, self.extra_keys = sequence, extra_keys

    @property
    def name(self) -> str:
        return self.sequence.name

    @property
    def meta(self) -> SequenceMeta:
        return self.sequence.meta

    def __len__(self) -> int:
        return self.meta.frame_count

    def __iter__(self) -> Iterator[dict[str, torch.Tensor]]:
        crop = self.sequence.full_frame()
        for t in range(len(self)):
            arrays = self.sequence.frames(t, 1, crop, self.extra_keys, reset_first=False)
            yield {k: torch.from_numpy(v) for k, v in arrays.items()}


def eval_sequences(
    root: str | Path | Iterable[str | Path],
    *,
    hr_buffers: Iterable[str] = (),
    lr_buffers: Iterable[str] = (),
    cache: bool = False,
    cache_dir: str | Path | None = None,
    progress: bool = True,
    needed_by: str = "",
    reference: str = "reference",
) -> list[SequenceFrames]:
    """Every sequence under ``root`` for evaluation or calibration, sorted by directory.

    Reads the EXR files by default (exact values); ``cache=True`` reuses the
    training cache instead.  ``reference`` is the HR buffer each frame carries as ``reference``.
    """
    extra = extra_buffer_keys(hr_buffers, lr_buffers)
    return [SequenceFrames(s, extra) for s in open_sequences(root, extra, cache, cache_dir, progress, needed_by, reference)]
