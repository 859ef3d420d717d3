"""The export stage's entry function: from a checkpoint (or a quantize directory) to a bundle on disk.

Steps: load the checkpoint; take the NPU files from a quantize directory or quantize the
reconstruction net for the bundle's size; place the stages on the device (optional); run the
golden frames; write the bundle atomically (:func:`.writer.write_bundle`).
"""

from __future__ import annotations

import logging
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..ops.runtimes import DEFAULT_RUNTIME
from .npu_stage import NpuArtifacts, load_quantized_dir, quantize_at

log = logging.getLogger(__name__)
GOLDEN_SCENE = "arena"  # built-in scene rendered for golden frames when no data of the right size is given


@dataclass
class ExportRequest:
    model: str  # checkpoint path or shipped name, or a quantize output directory
    out: Path
    checkpoint: str | None = None
    resolution: str | None = None  # "WxH" output size
    device: str | None = None
    placement: str = "default"
    data: Path | None = None
    method: str = "minmax"
    profile: str = DEFAULT_RUNTIME  # an ops.runtimes LiteRT runtime
    golden_frames: int = 3
    overwrite: bool = False
    progress: bool = True


def export(request: ExportRequest, timings: dict[str, float] | None = None) -> dict:
    """Write the bundle ``request.out``; returns its manifest.  ``timings``, if given, receives
    the wall-clock seconds of each phase (load, quantize, golden, write)."""
    from ..gpu.schedule import GpuStage, NpuBoundary
    from ..model import checkpoint
    from .golden import run_golden
    from .npu_files import read_tflite
    from .writer import BundleParts, write_bundle

    if request.golden_frames < 1:
        raise UserError("--golden-frames must be at least 1")
    if request.out.exists() and any(request.out.iterdir()) and not request.overwrite:
        raise UserError(f"output directory {request.out} exists and is not empty (use --overwrite)")
    clock = _Clock(timings)
    ckpt, npu, report = _sources(request)
    model, record = checkpoint.load(ckpt)
    _check_same_model(report, record, ckpt)
    hr_size = _bundle_size(request, npu, model.scale)
    lr_size = (hr_size[0] // model.scale, hr_size[1] // model.scale)
    stage = GpuStage.from_model(model.config, {k: v.detach().cpu().numpy() for k, v in model.state_dict().items()})
    placement = _placement(model, request, hr_size, Path(ckpt).stem)
    clock.lap("load")
    if npu is None:
        npu = quantize_at(model, Path(ckpt).stem, request.data, hr_size, request.method, request.progress)
    clock.lap("quantize")
    tflite = read_tflite(npu.tflite)
    _check_npu_io(tflite, hr_size)
    in_q, out_q = tflite.tensors[tflite.inputs[0]].qparams(), tflite.tensors[tflite.outputs[0]].qparams()
    pattern = record.get("jitter_pattern") or "mnss"
    frames, golden_source = golden_input_frames(request, lr_size, model.scale, pattern)
    log.info("running %d golden frames at %dx%d", len(frames), *hr_size)
    golden = run_golden(stage, frames, npu.tflite, NpuBoundary(*in_q, *out_q, profile=request.profile))
    clock.lap("golden")
    parts = BundleParts(
        model=model_section(ckpt, record),
        stage=stage,
        lr_size=lr_size,
        jitter_pattern=pattern,
        stages=[(name, placement_of(name, p, placement)) for name, _, p in model.stages()],
        npu=npu,
        profile=request.profile,
        golden=golden,
        golden_source=golden_source,
        placement=placement,
    )
    manifest = write_bundle(request.out, parts, overwrite=request.overwrite)
    clock.lap("write")
    return manifest


def _sources(request: ExportRequest) -> tuple[str, NpuArtifacts | None, dict]:
    """``(checkpoint, NPU files or None, quantize report)``: MODEL is a checkpoint, or a quantize
    directory whose checkpoint comes from ``--checkpoint`` (or its report)."""
    source = Path(request.model)
    if not source.is_dir() or _names_shipped_model(source):
        if request.checkpoint:
            raise UserError("--checkpoint goes with a quantize directory as MODEL; MODEL is already a checkpoint")
        return request.model, None, {}
    npu, report = load_quantized_dir(source)
    ckpt = request.checkpoint or (report.get("checkpoint") or {}).get("path")
    if not ckpt:
        raise UserError(f"{source} is a quantize directory: give the checkpoint it came from with --checkpoint")
    return ckpt, npu, report


def _names_shipped_model(directory: Path) -> bool:
    """A bare shipped name that only happens to match a local directory which is no quantize output
    (e.g. a training run ``./mnss_x2``): the shipped checkpoint, as in every other command."""
    from ..model.checkpoint import shipped_names

    return directory.parent == Path(".") and directory.name in shipped_names() and not (directory / "npu.tflite").exists()


class _Clock:
    """Wall-clock seconds per phase, into ``timings`` (a no-op without one)."""

    def __init__(self, timings: dict[str, float] | None):
        self.timings, self.last = timings, time.perf_counter()

    def lap(self, phase: str) -> None:
        now = time.perf_counter()
        if self.timings is not None:
            self.timings[phase] = now - self.last
        log.debug("export phase %s: %.2f s", phase, now - self.last)
        self.last = now


def _bundle_size(request: ExportRequest, npu: NpuArtifacts | None, scale: int) -> tuple[int, int]:
    from ..split.command import parse_resolution
    from .npu_files import read_tflite

    if npu is not None:
        tflite = read_tflite(npu.tflite)
        _, h, w, _ = tflite.tensors[tflite.inputs[0]].shape
        if request.resolution and parse_resolution(request.resolution) != (w, h):
            raise UserError(f"the quantize directory's npu.tflite runs at {w}x{h}, not {request.resolution}; "
                            f"export from the checkpoint to quantize for another size")
        size = (w, h)
    else:
        from .command import DEFAULT_RESOLUTION

        size = parse_resolution(request.resolution or DEFAULT_RESOLUTION)
    if size[0] % scale or size[1] % scale:
        raise UserError(f"output size {size[0]}x{size[1]} is not a multiple of the model's scale {scale}")
    return size


def _check_same_model(report: dict, record: dict, ckpt: str) -> None:
    """A quantize directory's report names the family and scale it was made from; the checkpoint must agree."""
    made_from = report.get("checkpoint") or {}
    for key in ("family", "scale"):
        if made_from.get(key) is not None and made_from.get(key) != record.get(key):
            raise UserError(f"the quantize directory was made from a {key} {made_from.get(key)!r} model, "
                            f"but {ckpt} is {record.get(key)!r}")


def _check_npu_io(tflite, hr_size: tuple[int, int]) -> None:
    if len(tflite.inputs) != 1 or len(tflite.outputs) != 1:
        raise UserError(f"npu.tflite has {len(tflite.inputs)} inputs and {len(tflite.outputs)} outputs; "
                        "a bundle's NPU graph takes one image and returns one")
    w, h = hr_size
    for name in tflite.inputs + tflite.outputs:
        t = tflite.tensors[name]
        if t.shape != [1, h, w, 3] or t.dtype != "int8" or len(t.scale) != 1:
            raise UserError(f"npu.tflite tensor '{name}' is {t.dtype} {t.shape}; the bundle needs int8 [1, {h}, {w}, 3] per-tensor quantized")


def _placement(model, request: ExportRequest, hr_size, name: str) -> dict | None:
    """The split stage's placement on ``request.device`` (None without a device)."""
    if request.device is None:
        return None
    from ..split.device import load_device
    from ..split.plan import split_model

    plan = split_model(model, load_device(request.device), request.placement, hr_size, model_name=name)
    on_npu = plan.npu_stages()
    if on_npu != ["recon"]:
        where = ", ".join(on_npu) if on_npu else "nothing"
        raise UserError(f"placement '{request.placement}' on {plan.device} runs {where} on the NPU; a bundle runs exactly "
                        "the reconstruction net there (try --placement default, or a device with an NPU)")
    return plan.to_dict()


def placement_of(name: str, model_placement: str, placement: dict | None) -> str:
    if placement is None:
        return model_placement
    return next(s["placement"] for s in placement["stages"] if s["name"] == name)


def model_section(ckpt: str, record: dict) -> dict:
    from ..model import checkpoint
    from .manifest import sha256_file

    path = checkpoint.resolve(ckpt)
    return {
        "id": Path(ckpt).stem,
        "family": record.get("family"),
        "config": record.get("config"),
        "checkpoint_sha256": sha256_file(path),
        "code_version": record.get("code_version"),
        "params": record.get("params"),
        "macs_per_pixel": record.get("macs_per_pixel"),
        "data_fingerprint": record.get("data_fingerprint"),
    }


def golden_input_frames(request: ExportRequest, lr_size, scale: int, pattern: str) -> tuple[list[dict], str]:
    """``golden_frames`` consecutive numpy frames at ``lr_size``: from ``request.data`` when a sequence
    there has that size, else rendered (built-in scene, EGL)."""
    from ..dataset.loader import eval_sequences

    n = request.golden_frames
    if request.data is not None and request.data.is_dir():
        for seq in eval_sequences(request.data, progress=False):
            if tuple(seq.meta.lr_size) == tuple(lr_size) and seq.meta.scale == scale and len(seq) >= n:
                return _first(seq, n), f"dataset {request.data}, sequence {seq.name}, frames 0..{n - 1}"
    with tempfile.TemporaryDirectory(prefix="mnss-export-golden-") as tmp:
        from ..render.config import RenderConfig, SequenceConfig
        from ..render.writer import render_dataset

        seq_cfg = SequenceConfig(name="golden", scene=GOLDEN_SCENE, seed=1, frames=n, lr_size=tuple(lr_size), scale=scale,
                                 jitter=pattern, hr_samples=1)
        render_dataset(RenderConfig(sequences=[seq_cfg]), Path(tmp), progress=request.progress)
        seq = eval_sequences(Path(tmp), progress=False)[0]
        return _first(seq, n), f"rendered: built-in scene '{GOLDEN_SCENE}', seed 1, frames 0..{n - 1}"


def _first(seq, n: int) -> list[dict]:
    from .golden import frame_from_torch

    frames = []
    for t, frame in enumerate(seq):
        if t >= n:
            break
        frames.append(frame_from_torch(frame))
    if not all(np.isfinite(f[k]).all() for f in frames for k in ("color", "depth", "motion")):
        raise UserError(f"golden frames from sequence '{seq.name}' contain NaN or Inf")
    return frames
