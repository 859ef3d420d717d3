"""The render stage's entry, :func:`render_dataset` (``mnss-kit render``): a data config into the
dataset format, frame by frame, shardable and resumable.

Every frame is a pure function of its time, so the frames of all sequences
(in config order) are dealt round-robin to ``N`` shards: shard ``I`` renders
global frames ``k`` with ``k % N == I``.  Every shard writes the same
``meta.json`` for every sequence, so shard outputs merge by copying
directories on top of each other.  A frame whose buffer files all exist is
skipped (resume after an interruption); each file is written atomically.

The native TAA reference (``extra_references: [taa]``) is the exception: frame
``k`` depends on the frames since the last reset.  Its history is not stored;
a shard or a resumed run re-runs the TAA from the last reset (camera cut or
sequence start) before each frame it writes, rendering only the one TAA pass
of the frames it does not write (``Renderer.advance_taa``).  So the history,
and every byte, is the same however the frames are split or resumed, and
shards still merge by copying; the price is one HR pass per skipped frame.
"""

from __future__ import annotations

import json
import logging
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import to_dict
from ..dataset.format import (
    BUFFERS, FORMAT_NAME, REFERENCE_BUFFERS, FORMAT_VERSION, FrameMeta, META_FILE, MotionConvention, SequenceMeta, buffer_path, write_buffer, write_meta,
)
from ..errors import UserError
from ..ops import native_taa
from ..ops.jitter import jitter_sequence, pattern_name
from . import gpu
from .camera import perspective
from .config import RenderConfig, SequenceConfig
from .scene import Scene

log = logging.getLogger(__name__)
RENDERER_NAME = "mnss-kit builtin deferred renderer (OpenGL 3.3, EGL)"


@dataclass
class RenderSummary:
    rendered: int
    skipped: int
    seconds: float
    sequences: list[str]


def frame_times(seq: SequenceConfig) -> np.ndarray:
    """``(frames,)`` float64 time of each frame in seconds."""
    return seq.start_time + np.arange(seq.frames) / seq.fps


def previous_time(seq: SequenceConfig, index: int) -> float:
    """Time of the frame before ``index``: exactly the previous frame's time (one frame earlier for frame 0),
    so each cut falls into exactly one ``(previous, current]`` interval."""
    times = frame_times(seq)
    return float(times[index - 1]) if index > 0 else float(times[0] - 1.0 / seq.fps)


def sequence_meta(seq: SequenceConfig, scene: Scene) -> SequenceMeta:
    """Metadata of a whole sequence; depends only on the config, never on a shard."""
    times = frame_times(seq)
    jitter = jitter_sequence(seq.jitter, seq.scale, seq.frames)
    aspect = frame_aspect(seq)
    frames = []
    for i, t in enumerate(times):
        state = scene.camera.state(float(t))
        proj = perspective(state.fov, aspect, scene.near, scene.far)
        reset = i == 0 or scene.camera.breaks_history(previous_time(seq, i), float(t), aspect)
        frames.append(FrameMeta(
            index=i, jitter=(float(jitter[i, 0]), float(jitter[i, 1])), reset=bool(reset), time=float(t),
            view=[float(v) for v in state.view().ravel()], proj=[float(v) for v in proj.ravel()],
        ))
    return SequenceMeta(
        format=FORMAT_NAME, version=FORMAT_VERSION, name=seq.name, scale=seq.scale,
        lr_size=tuple(seq.lr_size), hr_size=tuple(seq.hr_size), jitter_pattern=seq.jitter, frames=frames,
        near=scene.near, far=scene.far, reverse_z=False, depth_encoding="hardware",
        motion=MotionConvention(units="pixels", points_to="previous", y_axis="down", scale=1.0),
        color_space="linear_hdr", exposure=seq.exposure,
        buffers={res: list(written_buffers(seq, res)) for res in ("lr", "hr")},
        scene={**_config_record(seq), "renderer": RENDERER_NAME, "environment": gpu.environment(), "normal_space": "world",
               "hr_buffers": "1 sample at pixel centres; reference is the box-filtered mean of hr_samples",
               "identity": "color = emissive + fbeta * L (L demodulated radiance; fbeta = 0 on sky)",
               **_extra_reference_notes(seq)},
    )


def frame_aspect(seq: SequenceConfig) -> float:
    """Width / height of the view both cameras share: the display's (HR), as FSR2 renders its render
    size over the display's field of view.  At an integer scale this is the LR aspect to the last bit
    (``hr = s * lr`` on both axes: the same rational, correctly rounded); at a fractional one LR
    pixels are then a little off square (753x424 over 1280x720's view), so LR and HR see the same scene."""
    return seq.hr_size[0] / seq.hr_size[1]


def written_buffers(seq: SequenceConfig, res: str) -> list[str]:
    """The buffers a render of ``seq`` writes at ``res``: every one, less the references it does not ask for."""
    skipped = {REFERENCE_BUFFERS[r] for r in ("taa", "4x") if r not in seq.extra_references}
    return [name for name in BUFFERS[res] if name not in skipped]


def _config_record(seq: SequenceConfig) -> dict:
    """The sequence config for meta.json; without extra references the key is left out, and at an
    integer scale ``hr_size``, so such a render's meta.json (and dataset fingerprint) stays what it
    was before the keys existed."""
    record = to_dict(seq)
    if not seq.extra_references:
        del record["extra_references"]
    if isinstance(seq.scale, int):  # lr_size * scale: left out, as before the key existed
        del record["hr_size"]
    return record


def _extra_reference_notes(seq: SequenceConfig) -> dict:
    notes = {}
    if "taa" in seq.extra_references:
        notes["reference_taa"] = native_taa.describe()
    if "4x" in seq.extra_references:
        notes["reference_4x"] = "mean of 4 samples at the rotated-grid 4x MSAA positions (Direct3D standard pattern)"
    return notes


def frame_complete(seq_dir: Path, index: int, buffers: dict[str, list[str]]) -> bool:
    return all(buffer_path(seq_dir, res, name, index).is_file() for res, names in buffers.items() for name in names)


def frames_to_run(meta: SequenceMeta, todo: list[int], taa: bool) -> list[int]:
    """The frames to pass through the renderer, in order: ``todo``, and with the TAA reference also
    every frame back to the last reset before each (its history)."""
    if not taa or not todo:
        return todo
    last_reset, starts = 0, []
    for frame in meta.frames:
        last_reset = frame.index if frame.reset else last_reset
        starts.append(last_reset)
    return sorted({f for t in todo for f in range(starts[t], t + 1)})


def write_frame(seq_dir: Path, index: int, buffers: dict[str, dict[str, np.ndarray]]) -> None:
    for res, named in buffers.items():
        for name, image in named.items():
            if not np.all(np.isfinite(image)):
                raise RuntimeError(f"renderer produced non-finite values in {res}/{name} of frame {index}")
            write_buffer(seq_dir, res, name, index, image)


def _prepare_meta(seq_dir: Path, meta: SequenceMeta, overwrite: bool) -> None:
    path = seq_dir / META_FILE
    text = json.dumps(to_dict(meta), indent=2) + "\n"
    if path.is_file() and not overwrite:
        old, new = _current_names(json.loads(path.read_text())), json.loads(text)
        if "environment" not in old.get("scene", {}):  # rendered before meta recorded it: unknown, not different
            new = _without_environment(new)
        if old != new:
            raise UserError(f"{seq_dir} holds a sequence rendered {_difference(old, new)} (use --overwrite or another --out)")
        return
    write_meta(seq_dir, meta)


def _current_names(meta: dict) -> dict:
    """A ``meta.json`` on disk with its jitter pattern by today's name where the render records it
    (``jitter_pattern`` and the config's ``jitter`` in ``scene``): a sequence rendered before the
    pattern was renamed (``mnss``, now ``grid``) resumes, and keeps the name it was written with."""
    out = dict(meta)
    if isinstance(out.get("jitter_pattern"), str):
        out["jitter_pattern"] = pattern_name(out["jitter_pattern"])
    scene = out.get("scene")
    if isinstance(scene, dict) and isinstance(scene.get("jitter"), str):
        out["scene"] = {**scene, "jitter": pattern_name(scene["jitter"])}
    return out


def _difference(old: dict, new: dict) -> str:
    """How the sequence on disk differs from this render: its config, or only the environment."""
    if _without_environment(old) != _without_environment(new):
        return "with a different config"
    was = old["scene"]["environment"]  # the configs match, so both record one (_prepare_meta drops it from new otherwise)
    changed = [f"{k} {was.get(k)} -> {v}" for k, v in new["scene"]["environment"].items() if was.get(k) != v]
    return "on another machine or with other libraries (" + "; ".join(changed) + "), so its frames may differ in the last bits"


def _without_environment(meta: dict) -> dict:
    return {**meta, "scene": {k: v for k, v in meta.get("scene", {}).items() if k != "environment"}}


def parse_shard(text: str | None) -> tuple[int, int]:
    """``'I/N'`` -> (I, N) with 0 <= I < N."""
    if not text:
        return 0, 1
    try:
        i, n = (int(v) for v in text.split("/"))
    except ValueError:
        raise UserError(f"--shard expects I/N (e.g. 0/4), got '{text}'") from None
    if n < 1 or not 0 <= i < n:
        raise UserError(f"--shard {text}: need 0 <= I < N")
    return i, n


def render_dataset(cfg: RenderConfig, out_dir: str | Path, shard: tuple[int, int] = (0, 1),
                   overwrite: bool = False, progress: bool = True) -> RenderSummary:
    """Render the frames of shard ``shard`` of every sequence in ``cfg`` under ``out_dir/<name>/``."""
    from tqdm import tqdm

    from .renderer import FrameSpec, Renderer
    from .scenes import build_scene

    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise UserError(f"--out {out_dir} exists and is not a directory")
    index, count = shard
    offsets = np.cumsum([0] + [s.frames for s in cfg.sequences])
    mine = [[f for f in range(s.frames) if (offsets[k] + f) % count == index] for k, s in enumerate(cfg.sequences)]
    start = time.perf_counter()
    rendered = skipped = 0
    bar = tqdm(total=sum(map(len, mine)), unit="frame", disable=not progress, dynamic_ncols=True)
    try:
        for seq, frames in zip(cfg.sequences, mine):
            seq_dir = out_dir / seq.name
            scene = build_scene(seq, cfg)
            meta = sequence_meta(seq, scene)
            _prepare_meta(seq_dir, meta, overwrite)
            todo = [f for f in frames if overwrite or not frame_complete(seq_dir, f, meta.buffers)]
            skipped += len(frames) - len(todo)
            bar.update(len(frames) - len(todo))
            if not todo:
                continue
            bar.set_description(seq.name)
            renderer = Renderer(scene, tuple(seq.lr_size), seq.scale, seq.hr_samples, seq.extra_references,
                                hr_size=tuple(seq.hr_size))
            wanted = set(todo)
            # EXR compression of frame k overlaps with rendering frame k + 1 (one frame in flight)
            with ThreadPoolExecutor(max_workers=1) as pool:
                pending = None
                try:
                    for f in frames_to_run(meta, todo, "taa" in seq.extra_references):
                        fm = meta.frames[f]
                        spec = FrameSpec(fm.time, previous_time(seq, f), fm.jitter, index=f, reset=fm.reset)
                        if f not in wanted:
                            renderer.advance_taa(spec)
                            continue
                        buffers = renderer.render(spec)
                        if pending is not None:
                            pending.result()
                            bar.update(1)
                        pending = pool.submit(write_frame, seq_dir, f, buffers)
                        rendered += 1
                    pending.result()
                    bar.update(1)
                finally:
                    renderer.release()
    finally:
        bar.close()
    seconds = time.perf_counter() - start
    log.info("rendered %d frames (%d already present) in %.1f s", rendered, skipped, seconds)
    return RenderSummary(rendered, skipped, seconds, [s.name for s in cfg.sequences])
