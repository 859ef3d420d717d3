"""Dataset validation behind ``mnss-kit data check``: find what would silently spoil training.

Errors make the data unusable or wrong (missing or corrupt files, sizes that
contradict meta.json, NaN/Inf, impossible values); warnings are suspicious but
possible (large motion the reference does not bear out, a jitter sequence that is not the named pattern) or
come from heuristics: the LR colour is compared with the HR reference at the
jittered sample positions, and the previous reference is reprojected with the
motion vectors, each also with the signs flipped, to catch sign mistakes in an
exporter.  ``quick`` reads only the EXR headers.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import OpenEXR

from ..errors import UserError
from ..ops.jitter import PATTERNS, jitter_sequence, period
from ..ops.resample import bilinear_sample, pixel_grid
from ..ops.scale import INTEGER_SCALE_ONLY, MAX_SCALE, MIN_SCALE, parse_scale, upsample_motion_to
from ..ops.warp import warp_bilinear
from . import exr
from .format import BUFFERS, COLOUR_BUFFERS, META_FILE, REQUIRED_BUFFERS, SequenceMeta, buffer_path, canonical_motion, find_sequences, read_buffer, read_meta

UNIT_RANGE_BUFFERS = ("albedo", "roughness", "metallic")
log = logging.getLogger(__name__)

HEURISTIC_FRAMES = 4  # frames used by the sign heuristics
HEURISTIC_MARGIN = 0.8  # a flipped variant must beat the recorded one by this factor to warn
SIGN_MIN_MOTION = 1.0  # HR pixels: the motion sign heuristic compares only pixels moving at least this far
SIGN_MIN_PIXELS = 64  # ... and only frames with at least this many of them


@dataclass
class Problem:
    severity: str  # "error" or "warning"
    where: str
    message: str

    def line(self) -> str:
        return f"{self.severity}: {self.where}: {self.message}"


@dataclass
class Report:
    problems: list[Problem] = field(default_factory=list)
    sequences: int = 0
    frames: int = 0
    files: int = 0
    lacking: dict[str, int] = field(default_factory=dict)  # family -> sequences lacking a buffer it reads

    def error(self, where, message: str) -> None:
        self.problems.append(Problem("error", str(where), message))

    def warn(self, where, message: str) -> None:
        self.problems.append(Problem("warning", str(where), message))

    @property
    def errors(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == "error"]

    @property
    def warnings(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == "warning"]

    def summary(self) -> str:
        counts = f"{len(self.errors)} error(s), {len(self.warnings)} warning(s)"
        return f"{self.sequences} sequence(s), {self.frames} frames, {self.files} files checked: {counts}"


def check_dataset(root: str | Path, quick: bool = False, progress: bool = True, families: tuple[str, ...] = (),
                  scale=None) -> Report:
    """Check every sequence under ``root`` (a dataset or one sequence); never raises for bad data.

    ``families``: model families the data must serve; a buffer one of them reads that a sequence
    lacks is an error (without them, ``Report.lacking`` only counts such sequences per family), and
    so is a fractional scale for a family of integer scales only.  ``scale`` (``--scale``): the scale
    every sequence must have (a UserError when it is no scale at all: 0.5, 1.0, nan, 9).
    """
    expected = None if scale is None else parse_scale(scale, "--scale")
    root = Path(root)
    seqs = find_sequences(root)
    base = root.parent if (root / META_FILE).is_file() else root
    report = Report()
    from tqdm import tqdm

    with tqdm(desc="checking", unit="file", disable=None if progress else True) as bar:
        for seq in seqs:
            SequenceChecker(seq, base, report, quick, on_file=lambda: bar.update(1), families=families,
                            expected_scale=expected).run()
    return report


def require_clean(seq_or_root: str | Path) -> Report:
    """``data check``'s checks before a command reads ``seq_or_root``: what it calls an error refuses the
    data with its own line, what it warns about is logged as it would print it."""
    root = Path(seq_or_root)
    base = root.parent if (root / META_FILE).is_file() else root
    report = check_dataset(root, progress=False)
    if report.errors:
        first = report.errors[0]
        more = f" (and {len(report.errors) - 1} more error(s): mnss-kit data check lists them)" if len(report.errors) > 1 else ""
        raise UserError(f"data check: {base / first.where}: {first.message}{more}")
    for problem in report.warnings:
        log.warning("data check: %s: %s", base / problem.where, problem.message)
    return report


def missing_family_buffers(meta: SequenceMeta, family_name: str) -> list[str]:
    """``res/name`` of each dataset buffer family ``family_name`` reads that ``meta`` does not list."""
    from ..model.families import family_named

    needed = family_named(family_name).dataset_buffers()
    return [f"{res}/{name}" for res, names in needed.items() for name in names if name not in meta.buffers.get(res, [])]


class SequenceChecker:
    def __init__(self, seq: Path, base: Path, report: Report, quick: bool, on_file=None, families: tuple[str, ...] = (),
                 expected_scale=None):
        self.seq, self.base, self.report, self.quick, self.families = seq, base, report, quick, families
        self.expected_scale = expected_scale
        self.on_file = on_file or (lambda: None)
        self.meta: SequenceMeta | None = None

    def rel(self, path: Path) -> str:
        return path.relative_to(self.base).as_posix()

    def run(self) -> None:
        meta_path = self.seq / META_FILE
        self.report.sequences += 1
        try:
            self.meta = read_meta(self.seq)
        except UserError as e:
            self.report.error(self.rel(meta_path), str(e).removeprefix(f"{meta_path}: ").removeprefix(f"{meta_path}:"))
            return
        self.report.frames += self.meta.frame_count
        if not self.check_meta(self.rel(meta_path)):
            return
        self.check_family_buffers(self.rel(meta_path))
        for res, buffer in self.buffers():
            self.check_buffer_files(res, buffer)
        self.check_unlisted_dirs()
        if not self.quick:
            self.check_jitter_sign()
            self.check_motion_sign()

    # -- meta.json --------------------------------------------------------------------------------

    def check_meta(self, where: str) -> bool:
        """Consistency of meta.json itself; False if the files cannot be checked against it."""
        m, err, warn = self.meta, self.report.error, self.report.warn
        ok = True
        if not _scale_ok(m.scale) or min(m.lr_size) < 1:
            err(where, f"scale must be an integer >= 2 or in [{MIN_SCALE}, {MAX_SCALE}], and lr_size positive "
                       f"(scale {m.scale}, lr_size {m.lr_size})")
            ok = False
        if self.expected_scale is not None and m.scale != self.expected_scale:
            err(where, f"scale {m.scale}, but --scale is {self.expected_scale}")
        if not m.frames:
            err(where, "no frames")
            return False
        if len(m.frames) == 1:
            warn(where, "1 frame: training needs several consecutive frames, and a method's history is never judged")
        wrong = [(i, f.index) for i, f in enumerate(m.frames) if f.index != i]
        if wrong:
            err(where, f"frames[{wrong[0][0]}].index is {wrong[0][1]}: frames must be numbered 0, 1, 2, ... in order")
            ok = False
        if not 0.0 <= m.near < m.far or (m.depth_encoding == "hardware" and m.near <= 0.0):
            err(where, f"near {m.near} / far {m.far}: need 0 < near < far (hardware depth) or 0 <= near < far (linear)")
        if m.color_space == "linear_hdr" and not m.exposure > 0.0:
            err(where, f"exposure must be > 0, got {m.exposure}")
        if m.motion.scale == 0.0:
            err(where, "motion.scale is 0: every motion vector would be zero")
        for res, names in m.buffers.items():
            if res not in BUFFERS:
                err(where, f"buffers has unknown resolution '{res}' (lr or hr)")
                continue
            for name in names:
                if name not in BUFFERS[res]:
                    err(where, f"unknown buffer {res}/{name} (known: {', '.join(BUFFERS[res])})")
        for res, names in REQUIRED_BUFFERS.items():
            for name in names:
                if name not in m.buffers.get(res, []):
                    err(where, f"required buffer {res}/{name} missing from buffers.{res}")
        if not m.frames[0].reset:
            warn(where, "frame 0 has reset false; a sequence's first frame has no history (the loader resets it anyway)")
        self.check_jitter_values(where)
        return ok

    def check_family_buffers(self, where: str) -> None:
        from ..model.families import FAMILIES

        if isinstance(self.meta.scale, float):
            for name in self.families:
                if name in INTEGER_SCALE_ONLY:
                    self.report.error(where, f"the {name} family takes integer scales only ({INTEGER_SCALE_ONLY[name]}); "
                                             f"this sequence is x{self.meta.scale:g}")

        for name in FAMILIES:
            missing = missing_family_buffers(self.meta, name)
            if not missing:
                continue
            self.report.lacking[name] = self.report.lacking.get(name, 0) + 1
            if name in self.families:
                self.report.error(where, f"the {name} family reads {', '.join(missing)}, which this sequence lacks "
                                  "(docs/dataset.md lists each family's buffers and how to export them)")

    def check_jitter_values(self, where: str) -> None:
        m = self.meta
        jit = np.array([f.jitter for f in m.frames], dtype=np.float64)
        not_finite = np.nonzero(~np.isfinite(jit).all(axis=1))[0]
        if len(not_finite):
            t = int(not_finite[0])
            self.report.error(where, f"jitter of {len(not_finite)} frame(s) is NaN or infinite (frame {t}: {_pair(jit[t])})")
            return
        outside = np.nonzero(((jit < -0.5) | (jit >= 0.5)).any(axis=1))[0]
        if len(outside):
            t = int(outside[0])
            self.report.error(
                where,
                f"jitter of {len(outside)} frame(s) outside [-0.5, 0.5) LR pixels (frame {t}: {_pair(jit[t])}); "
                "jitter is in LR pixels from the pixel centre",
            )
            return
        if m.jitter_pattern not in PATTERNS:
            self.report.warn(where, f"jitter_pattern '{m.jitter_pattern}' is not one of {', '.join(PATTERNS)}: offsets not verified")
            return
        try:
            p = period(m.jitter_pattern, m.scale)
            expected = jitter_sequence(m.jitter_pattern, m.scale, len(jit) + p)
        except UserError as e:
            self.report.warn(where, f"jitter offsets not verified: {e}")
            return
        if _matches_some_phase(jit, expected, p):
            return
        if _matches_some_phase(-jit, expected, p):
            self.report.warn(where, f"jitter offsets are the '{m.jitter_pattern}' pattern negated: the jitter sign looks inverted (docs/dataset.md, Jitter)")
            return
        t = _first_mismatch(jit, expected, p)
        self.report.warn(where, f"jitter offsets do not follow the '{m.jitter_pattern}' pattern at scale {m.scale} "
                                f"(from frame {t}: {_pair(jit[t])})")

    # -- files ------------------------------------------------------------------------------------

    def buffers(self) -> list[tuple[str, str]]:
        return [(r, b) for r, names in self.meta.buffers.items() if r in BUFFERS for b in names if b in BUFFERS[r]]

    def check_buffer_files(self, res: str, buffer: str) -> None:
        folder = self.seq / res / buffer
        if not folder.is_dir():
            self.report.error(self.rel(folder), f"buffer directory missing ({self.meta.frame_count} frames expected)")
            return
        present = {p.name for p in folder.glob("*.exr") if not p.name.startswith(".")}
        expected = set()
        for t, frame in enumerate(self.meta.frames):
            path = buffer_path(self.seq, res, buffer, frame.index)
            expected.add(path.name)
            if path.name not in present:
                self.report.error(self.rel(path), "missing frame")
                continue
            self.report.files += 1
            self.check_file(path, res, buffer, t)
            self.on_file()
        extra = sorted(present - expected)
        if extra:
            self.report.warn(self.rel(folder), f"{len(extra)} file(s) with no frame in meta.json (e.g. {extra[0]}): ignored")

    def check_unlisted_dirs(self) -> None:
        for res in BUFFERS:
            folder = self.seq / res
            if not folder.is_dir():
                continue
            for sub in sorted(folder.iterdir()):
                if sub.is_dir() and not sub.name.startswith(".") and sub.name not in self.meta.buffers.get(res, []):
                    self.report.warn(self.rel(sub), f"not listed in meta.json buffers.{res}: ignored by the loader")

    def check_file(self, path: Path, res: str, buffer: str, t: int) -> None:
        where, spec = self.rel(path), BUFFERS[res][buffer]
        try:
            with OpenEXR.File(str(path), header_only=True) as f:  # the header is only valid while open
                names = sorted(c.name for c in f.header()["channels"])
                lo, hi = f.header()["dataWindow"]
        except Exception:  # the bindings raise plain exceptions for corrupt files
            self.report.error(where, "not a readable OpenEXR file (corrupt or truncated header)")
            return
        missing = [c for c in spec.channels if c not in names]
        if missing:
            self.report.error(where, f"missing channel(s) {', '.join(missing)} (has {', '.join(names)})")
            return
        w, h = int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1)
        ew, eh = self.meta.lr_size if res == "lr" else self.meta.hr_size
        if (w, h) != (ew, eh):
            self.report.error(where, f"size {w}x{h} does not match meta {res}_size {ew}x{eh}{self.scale_hint(res, w, h)}")
            return
        if self.quick:
            return
        try:
            raw = exr.read_exr(path, spec.channels)
        except UserError:
            self.report.error(where, "corrupt or truncated OpenEXR data (the header reads, the pixels do not)")
            return
        self.check_values(where, raw, res, buffer, t)

    def scale_hint(self, res: str, w: int, h: int) -> str:
        lw, lh = self.meta.lr_size
        if res == "hr" and w % lw == 0 and h % lh == 0 and w // lw == h // lh:
            return f" (it is {w // lw}x lr_size: is meta scale {self.meta.scale} wrong?)"
        return ""

    def check_values(self, where: str, raw: np.ndarray, res: str, buffer: str, t: int) -> None:
        """Value checks on one decoded ``(H, W, C)`` float32 buffer as stored, of the ``t``-th frame."""
        m, err, warn = self.meta, self.report.error, self.report.warn
        reset = m.frames[t].reset
        bad = ~np.isfinite(raw)
        if bad.any():
            y, x = np.argwhere(bad.any(axis=-1))[0]
            err(where, f"{int(bad.sum())} NaN/Inf value(s), first at x={x} y={y}")
            return
        lo, hi = float(raw.min()), float(raw.max())
        if buffer == "depth":
            if m.depth_encoding == "hardware" and (lo < 0.0 or hi > 1.0):
                err(where, f"hardware depth outside [0, 1] (min {lo:g}, max {hi:g}); linear depth needs depth_encoding 'linear'")
            elif m.depth_encoding == "linear" and lo < 0.0:
                warn(where, f"negative linear depth (min {lo:g}); view depth is positive in front of the camera")
        elif buffer == "motion" and not reset:  # motion across a camera cut means nothing and is not used
            self.check_motion_range(where, raw, res, t)
        elif buffer in COLOUR_BUFFERS:
            if m.color_space == "linear_hdr" and lo < -1e-3:
                warn(where, f"negative colour values (min {lo:g}) in linear HDR")
            elif m.color_space == "display" and (lo < -1e-3 or hi > 1.001):
                warn(where, f"display colour outside [0, 1] (min {lo:g}, max {hi:g}): clipped when loaded")
        elif buffer in UNIT_RANGE_BUFFERS and (lo < -1e-3 or hi > 1.001):
            warn(where, f"{buffer} outside [0, 1] (min {lo:g}, max {hi:g})")

    def check_motion_range(self, where: str, raw: np.ndarray, res: str, t: int) -> None:
        w, h = self.meta.lr_size if res == "lr" else self.meta.hr_size
        mv = canonical_motion(raw, self.meta, (w, h))
        over = (np.abs(mv[..., 0]) > w / 2) | (np.abs(mv[..., 1]) > h / 2)
        if not over.any():
            return
        if over.mean() > 0.5:
            self.report.error(
                where,
                f"motion of {over.mean():.0%} of pixels exceeds half the image (max {float(np.abs(mv).max()):.1f} px): "
                "check meta motion.units and motion.scale",
            )
            return
        # A pixel whose previous position is off the previous frame came into view (a fast turn, or a
        # surface behind the previous camera, which the motion convention points off-screen): its
        # history is none, however far the motion points.  A long motion that lands inside is suspect
        # unless the reference bears it out, as it does in a fast pan.
        ys, xs = np.nonzero(over)
        px, py = xs + 0.5 + mv[ys, xs, 0], ys + 0.5 + mv[ys, xs, 1]
        inside = (px >= 0) & (px < w) & (py >= 0) & (py < h)
        if not inside.any():
            return
        ys, xs = ys[inside], xs[inside]
        if self.reference_follows_motion(res, t, ys, xs, mv[ys, xs]):
            return
        longest = float(np.abs(mv[ys, xs]).max())
        self.report.warn(where, f"{ys.size} pixel(s) move more than half the image in one frame to a place inside "
                                f"the previous one (max {longest:.1f} px), and the reference does not follow them: "
                                "check meta motion.units and motion.scale")

    def reference_follows_motion(self, res: str, t: int, ys: np.ndarray, xs: np.ndarray, mv: np.ndarray) -> bool:
        """The previous reference fetched where the motion of pixels ``ys, xs`` (of ``res``, in the ``t``-th
        frame) points matches this frame's reference there clearly better than fetched unmoved or with
        the motion multiplied or divided by the scale (the units mistakes that make motion long).  The
        reference, not the LR colour, so that aliasing and jitter do not blur the comparison."""
        m = self.meta
        if t == 0:
            return False
        try:
            prev = read_buffer(self.seq, m, "hr", "reference", m.frames[t - 1].index)
            cur = read_buffer(self.seq, m, "hr", "reference", m.frames[t].index)
        except UserError:  # a missing or corrupt reference is reported where it is checked
            return False
        rx, ry = _ratios(m) if res == "lr" else (1, 1)
        x, y = (xs + np.float32(0.5)) * np.float32(rx), (ys + np.float32(0.5)) * np.float32(ry)
        here = bilinear_sample(cur, x, y)

        def error(factor: float) -> float:
            fetched = bilinear_sample(prev, x + np.float32(factor * rx) * mv[:, 0], y + np.float32(factor * ry) * mv[:, 1])
            return float(np.mean(np.abs(fetched - here)))

        return error(1.0) < HEURISTIC_MARGIN * min(error(f) for f in _units_mistakes(m.scale).values())

    # -- sign heuristics (full check only) ----------------------------------------------------------

    def check_jitter_sign(self) -> None:
        """The LR colour should match the reference at the jittered sample positions, not the mirrored ones."""
        m = self.meta
        frames = [t for t, f in enumerate(m.frames) if max(abs(f.jitter[0]), abs(f.jitter[1])) >= 0.1]
        errors = []
        for t in _spread(frames, HEURISTIC_FRAMES):
            try:
                lr = read_buffer(self.seq, m, "lr", "color", m.frames[t].index)
                ref = read_buffer(self.seq, m, "hr", "reference", m.frames[t].index)
            except UserError:
                return  # already reported as a file problem
            x, y = pixel_grid(*lr.shape[:2])
            jx, jy = m.frames[t].jitter
            rx, ry = _ratios(m)
            errs = []
            for sign in (1.0, -1.0):
                seen = bilinear_sample(ref, (x + sign * jx) * rx, (y + sign * jy) * ry)
                errs.append(float(np.mean(np.abs(seen - lr))))
            errors.append(errs)
        if not errors or not all(np.isfinite(errors).flat):
            return
        recorded, negated = np.median(np.array(errors), axis=0)
        if negated < HEURISTIC_MARGIN * recorded:
            self.report.warn(
                self.rel(self.seq),
                f"LR colour matches the reference better with the jitter negated (mean error {negated:.4f} vs {recorded:.4f}): "
                "the jitter sign looks inverted (docs/dataset.md, Jitter)",
            )

    def check_motion_sign(self) -> None:
        """Reprojecting the previous reference with the LR motion should beat flipped or zero motion, on
        the pixels that move at least SIGN_MIN_MOTION HR pixels."""
        m = self.meta
        pairs = [t for t in range(1, m.frame_count) if not m.frames[t].reset]
        variants = {
            "as recorded": (1, 1),
            "negated": (-1, -1),
            "with x negated": (-1, 1),
            "with y negated": (1, -1),
            **{name: (f, f) for name, f in _units_mistakes(m.scale).items()},
        }
        errors = []
        for t in _spread(pairs, HEURISTIC_FRAMES):
            try:
                prev = read_buffer(self.seq, m, "hr", "reference", m.frames[t - 1].index)
                cur = read_buffer(self.seq, m, "hr", "reference", m.frames[t].index)
                mv = upsample_motion_to(read_buffer(self.seq, m, "lr", "motion", m.frames[t].index), m.scale, m.hr_size)
            except UserError:
                return
            # Only pixels that move tell the variants apart: on still ones a packed motion's rounding
            # (a hundredth of a pixel) would make "set to zero" win on a still camera.
            moving = np.hypot(mv[..., 0], mv[..., 1]) >= SIGN_MIN_MOTION
            if moving.sum() < SIGN_MIN_PIXELS:
                continue
            errors.append([float(np.mean(np.abs(warp_bilinear(prev, mv * np.float32(v)) - cur)[moving]))
                           for v in variants.values()])
        if not errors or not all(np.isfinite(errors).flat):
            return
        med = dict(zip(variants, np.median(np.array(errors), axis=0)))
        best = min(med, key=med.get)
        if best == "as recorded" or med[best] >= HEURISTIC_MARGIN * med["as recorded"]:
            return
        if best == "set to zero" or "scale" in best:
            hint = "check meta motion.units and motion.scale (LR motion is in LR pixels)"
        else:
            hint = "check meta motion.points_to and motion.y_axis (docs/dataset.md, Motion vectors)"
        self.report.warn(
            self.rel(self.seq),
            f"reprojecting the reference works better with the motion {best} (mean error {med[best]:.4f} vs {med['as recorded']:.4f}): {hint}",
        )


def _units_mistakes(scale) -> dict[str, float]:
    """The motion factors of the usual units mistakes, by how ``data check`` names them: no motion
    written, HR pixels written into the LR buffer, or the reverse."""
    s = float(scale)
    return {"set to zero": 0.0, f"multiplied by the scale ({scale})": s, f"divided by the scale ({scale})": 1.0 / s}


def _scale_ok(scale) -> bool:
    if isinstance(scale, int):
        return scale >= 2
    return math.isfinite(scale) and MIN_SCALE <= scale <= MAX_SCALE


def _ratios(m: SequenceMeta) -> tuple[float, float]:
    """HR pixels per LR pixel on each axis: the scale itself (an integer scale, as always), or the exact
    per-axis ratio ``hr / lr`` (a fractional one)."""
    if isinstance(m.scale, int):
        return m.scale, m.scale
    return tuple(float(r) for r in m.ratios)


def _matches_some_phase(recorded: np.ndarray, expected: np.ndarray, p: int) -> bool:
    n = len(recorded)
    return any(np.allclose(recorded, expected[k : k + n], atol=1e-3) for k in range(p))


def _first_mismatch(recorded: np.ndarray, expected: np.ndarray, p: int) -> int:
    """The first frame that departs from the pattern, at the phase the recorded offsets follow longest."""
    n = len(recorded)
    firsts = []
    for k in range(p):
        off = ~np.isclose(recorded, expected[k : k + n], atol=1e-3).all(axis=1)
        firsts.append(int(np.argmax(off)) if off.any() else n)
    return min(max(firsts), n - 1)


def _pair(values) -> str:
    return "(" + ", ".join(f"{float(v):g}" for v in values) + ")"


def _spread(items: list[int], count: int) -> list[int]:
    """Up to ``count`` items evenly spread over ``items``."""
    if len(items) <= count:
        return items
    return [items[round(i * (len(items) - 1) / (count - 1))] for i in range(count)]
