"""The export stage's entry function: from a checkpoint (or a quantize directory) to a bundle on disk.

Steps: load the checkpoint; take the NPU files from a quantize directory or quantize the
reconstruction net for the bundle's size; place the stages on the device (optional); run the
golden frames; read the recorded sequence (optional); write the bundle atomically (:func:`.writer.write_bundle`).
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
    scale: int | float | None = None  # --scale: the bundle's scale (a fractional-scale family may run at another than its config's)
    device: str | None = None
    placement: str = "default"
    data: Path | None = None
    method: str = "minmax"
    profile: str = DEFAULT_RUNTIME  # an ops.runtimes LiteRT runtime
    golden_frames: int = 3
    sequence: Path | None = None  # dataset whose first sequence at the bundle's size the bundle carries
    sequence_frames: int = 0
    overwrite: bool = False
    progress: bool = True


def export(request: ExportRequest, timings: dict[str, float] | None = None) -> dict:
    """Write the bundle ``request.out``; returns its manifest.  ``timings``, if given, receives
    the wall-clock seconds of each phase (load, quantize, golden, write)."""
    from ..model import checkpoint
    from ..model.families import family_of
    from .golden import run_golden
    from .npu_files import read_tflite
    from .writer import TFLITE_NAME, BundleParts, write_bundle

    if request.golden_frames < 1:
        raise UserError("--golden-frames must be at least 1")
    if request.sequence is not None and request.sequence_frames < 1:
        raise UserError("--frames must be at least 1")
    if request.out.exists() and any(request.out.iterdir()) and not request.overwrite:
        raise UserError(f"output directory {request.out} exists and is not empty (use --overwrite)")
    clock = _Clock(timings)
    ckpt, npu, report = _sources(request)
    model, record = checkpoint.load(ckpt)
    if npu is not None:
        _check_same_model(report, ckpt, request.model)
    _apply_scale(model, request.scale, Path(ckpt).stem)
    hr_size = _bundle_size(request, npu, model.scale, family_of(model).npu_output_at_lr)
    lr_size = bundle_lr_size(hr_size, model.scale)
    fractional = not float(model.scale).is_integer()
    if fractional:
        model.set_output_size(hr_size)  # the model's own frames (calibration) come out at the bundle's HR size
    if request.data is not None:  # before the slow part
        check_data(request.data, model.scale, Path(ckpt).stem, lr_size, request.golden_frames)
    placement = _placement(model, request, hr_size, Path(ckpt).stem)
    clock.lap("load")
    if npu is None:
        npu = quantize_at(model, Path(ckpt).stem, request.data, hr_size, request.method, request.progress,
                          jitter=checkpoint.bundle_pattern(record, model.scale))
    clock.lap("quantize")
    tflite = read_tflite(npu.tflite)
    _check_npu_io(tflite)
    npu_io = {"model": TFLITE_NAME, "input": tflite.inputs[0], "output": tflite.outputs[0],
              "input_q": tflite.tensors[tflite.inputs[0]].plain_qparams(), "output_q": tflite.tensors[tflite.outputs[0]].plain_qparams()}
    state = {k: v.detach().cpu().numpy() for k, v in model.state_dict().items()}
    extra = {"hr_size": hr_size} if fractional else {}  # integer scales: every family's plan as before
    plan = family_of(model).gpu_plan(model.config, state, lr_size, npu_io, request.profile, **extra)
    _check_boundary_sizes(tflite, plan)
    pattern = checkpoint.bundle_pattern(record, model.scale)
    inputs = [r["name"] for r in plan["resources"] if r["role"] == "input"]
    frames, golden_source = golden_input_frames(request, lr_size, model.scale, pattern, inputs)
    log.info("running %d golden frames at %dx%d", len(frames), *hr_size)
    golden = run_golden(plan, frames, npu.tflite, request.profile, model.scale)
    clock.lap("golden")
    sequence = None
    if request.sequence is not None:
        from .sequence import sequence_frames

        sequence = sequence_frames(request.sequence, lr_size, model.scale, inputs, request.sequence_frames)
    section = model_section(ckpt, record)
    if isinstance(section["config"], dict) and section["config"].get("scale") != model.scale:  # --scale: the config it runs
        section["config"] = {**section["config"], "scale": model.scale}
    parts = BundleParts(
        model=section,
        plan=plan,
        scale=model.scale,
        lr_size=lr_size,
        jitter_pattern=pattern,
        stages=[(name, placement_of(name, p, placement)) for name, _, p in model.stages()],
        npu=npu,
        profile=request.profile,
        golden=golden,
        golden_source=golden_source,
        placement=placement,
        sequence=sequence,
        hr_size=hr_size if fractional else None,
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


def _apply_scale(model, scale, name: str) -> None:
    """``--scale``: the model's own scale, or any scale for a family that takes fractional ones (its
    net runs at LR; the bundle runs it at that scale); a one-line UserError otherwise."""
    from ..ops.scale import INTEGER_SCALE_ONLY
    from ..model.families import family_of

    if scale is None or float(scale) == float(model.scale):
        return
    family = family_of(model).name
    if family in INTEGER_SCALE_ONLY or not hasattr(model, "set_output_size"):
        raise UserError(f"--scale {scale}: {name} is x{model.scale} and the {family} family runs at the scale it was built for "
                        f"only (leave out --scale)")
    if not getattr(model.config, "scale_input", True):
        log.warning("%s was trained at x%s and has no scale input; the bundle runs it at x%s", name, model.config.scale, scale)
    model.config.scale = scale
    model.scale = scale


def bundle_lr_size(hr_size, scale) -> tuple[int, int]:
    """The LR size of an HR size: ``hr / s`` at an integer scale, ``round_half_up(hr / s)`` per axis
    at a fractional one (``ops.scale.lr_size_for``: 1280x720 at 1.5 is 853x480, at 1.7 753x424)."""
    from ..ops.scale import lr_size_for

    if float(scale).is_integer():
        return hr_size[0] // int(scale), hr_size[1] // int(scale)
    return tuple(lr_size_for(hr_size, scale))


def _bundle_size(request: ExportRequest, npu: NpuArtifacts | None, scale: int, output_at_lr: bool = False) -> tuple[int, int]:
    """The HR size: the quantize directory's (its NPU output is the HR image, or with ``output_at_lr``
    the LR one), else ``--resolution`` or the default."""
    from ..split.inputs import DEFAULT_RESOLUTION, parse_resolution, require_scale_multiple
    from .npu_files import read_tflite

    if npu is not None:
        tflite = read_tflite(npu.tflite)
        _, h, w, _ = tflite.tensors[tflite.outputs[0]].shape  # the NPU's output is the HR image (its input may be LR)
        if output_at_lr:  # the even LR size: at a fractional scale --resolution names the HR size
            if not float(scale).is_integer():
                if not request.resolution:
                    raise UserError(f"a x{scale:g} quantize directory needs --resolution WxH (the output size it runs at)")
                return parse_resolution(request.resolution)
            w, h = w * scale, h * scale
        if request.resolution and parse_resolution(request.resolution) != (w, h):
            raise UserError(f"the quantize directory's npu.tflite runs at {w}x{h}, not {request.resolution}; "
                            f"export from the checkpoint to quantize for another size")
        size = (w, h)
    else:
        size = parse_resolution(request.resolution) if request.resolution else DEFAULT_RESOLUTION
    if float(scale).is_integer():
        require_scale_multiple(size, int(scale))
    return size


def _check_same_model(report: dict, ckpt: str, directory: str) -> None:
    """The NPU files of a quantize directory hold the weights of the checkpoint they were quantized
    from; a bundle pairing them with another one would run two different models."""
    from ..model import checkpoint

    made_from = report["checkpoint"]  # load_quantized_dir checked it records a SHA-256
    given = checkpoint.digest(ckpt)
    if given == made_from["sha256"]:
        return
    then, now = made_from["sha256"][:12], given[:12]
    if str(made_from.get("path")) == str(ckpt):
        raise UserError(f"{ckpt} changed since {directory} was quantized from it (SHA-256 {then}... then, {now}... now); "
                        "quantize it again")
    raise UserError(f"{directory} was quantized from {made_from.get('path')} (SHA-256 {then}...), not from {ckpt} "
                    f"(SHA-256 {now}...); give --checkpoint the file it came from")


def _check_npu_io(tflite) -> None:
    if len(tflite.inputs) != 1 or len(tflite.outputs) != 1:
        raise UserError(f"npu.tflite has {len(tflite.inputs)} inputs and {len(tflite.outputs)} outputs; "
                        "a bundle's NPU graph takes one image and returns one")
    for name in tflite.inputs + tflite.outputs:
        t = tflite.tensors[name]
        if t.dtype != "int8" or t.scale.size != 1 or len(t.shape) != 4 or t.shape[0] != 1:
            raise UserError(f"npu.tflite tensor '{name}' is {t.dtype} {list(t.shape)}; the bundle needs an int8 [1, H, W, C] "
                            "per-tensor quantized tensor")


def _check_boundary_sizes(tflite, plan: dict) -> None:
    """Each NPU tensor fits the boundary buffer the schedule gives it (4 int8 values per word)."""
    buffers = {r["name"]: r for r in plan["resources"]}
    for step in (s for s in plan["schedule"]["steps"] if s["kind"] == "npu"):
        for tensor, buffer in {**step["inputs"], **step["outputs"]}.items():
            values = int(np.prod(tflite.tensors[tensor].shape))
            if buffers[buffer]["words"] != -(-values // 4):
                raise UserError(f"npu.tflite tensor '{tensor}' has shape {list(tflite.tensors[tensor].shape)}, which does not "
                                f"fit the bundle buffer '{buffer}' ({buffers[buffer]['words']} words): export at the "
                                "size the quantize directory was made for")


def _placement(model, request: ExportRequest, hr_size, name: str) -> dict | None:
    """The split stage's placement on ``request.device`` (None without a device)."""
    if request.device is None:
        return None
    from ..model.families import family_of
    from ..split.device import load_device
    from ..split.plan import split_model

    plan = split_model(model, load_device(request.device), request.placement, hr_size, model_name=name)
    on_npu = plan.npu_stages()
    expected = list(family_of(model).npu_stages)
    if on_npu != expected:
        where = ", ".join(on_npu) if on_npu else "nothing"
        raise UserError(f"placement '{request.placement}' on {plan.device} runs {where} on the NPU; a bundle runs exactly "
                        f"the family's NPU stage ({', '.join(expected)}) there (try --placement default, or a device with an NPU)")
    return plan.to_dict()


def placement_of(name: str, model_placement: str, placement: dict | None) -> str:
    if placement is None:
        return model_placement
    return next(s["placement"] for s in placement["stages"] if s["name"] == name)


def model_section(ckpt: str, record: dict) -> dict:
    from ..model import checkpoint
    from ..fileio import sha256_file

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


def check_data(data: Path, scale: int, model_id: str, lr_size: tuple[int, int], golden_frames: int) -> None:
    """``--data`` exists, every sequence in it is at the model's scale (frames of another scale can
    neither calibrate the model nor serve as its golden frames), and if sequences at the bundle's
    LR size are there, one has the golden frames asked for."""
    from ..dataset.format import find_sequences, read_meta

    if not data.is_dir():
        raise UserError(f"--data {data}: not a directory")
    fitting = {}
    for seq_dir in find_sequences(data):
        meta = read_meta(seq_dir)
        if meta.scale != scale:
            raise UserError(f"{seq_dir}: sequence '{meta.name}' is x{meta.scale}, but {model_id} is x{scale}; "
                            f"give --data of the model's scale")
        if tuple(meta.lr_size) == tuple(lr_size):
            fitting[meta.name] = meta.frame_count
    if fitting and max(fitting.values()) < golden_frames:
        name = max(fitting, key=fitting.get)
        raise UserError(f"--golden-frames {golden_frames}: the longest sequence of {data} at {lr_size[0]}x{lr_size[1]} "
                        f"('{name}') has {fitting[name]} frames; ask for at most {fitting[name]}")


def golden_input_frames(request: ExportRequest, lr_size, scale: int, pattern: str, inputs: list[str]) -> tuple[list[dict], str]:
    """``golden_frames`` consecutive numpy frames at ``lr_size``: from ``request.data`` when a sequence
    there has that size (:func:`check_data` has refused data whose sequences at that size are too
    short), else rendered (built-in scene, EGL), with a warning when data was given."""
    from ..dataset.format import extra_buffers_of
    from ..dataset.loader import eval_sequences
    from .golden import dataset_frames, first_frames

    n = request.golden_frames
    if request.data is not None:
        found = dataset_frames(request.data, lr_size, scale, inputs, n)
        if found is not None:
            return found
        log.warning("%s has no sequence at the bundle's LR size %dx%d: the golden frames are rendered from the built-in "
                    "scene '%s' instead (add a sequence at that size to --data to use your frames)",
                    request.data, *lr_size, GOLDEN_SCENE)
    with tempfile.TemporaryDirectory(prefix="mnss-export-golden-") as tmp:
        from ..render.config import RenderConfig, SequenceConfig
        from ..render.run import render_dataset

        seq_cfg = SequenceConfig(name="golden", scene=GOLDEN_SCENE, seed=1, frames=n, lr_size=tuple(lr_size), scale=scale,
                                 jitter=pattern, hr_samples=1)
        render_dataset(RenderConfig(sequences=[seq_cfg]), Path(tmp), progress=request.progress)
        seq = eval_sequences(Path(tmp), **extra_buffers_of(inputs), progress=False)[0]
        return first_frames(seq, n, inputs), f"rendered: built-in scene '{GOLDEN_SCENE}', seed 1, frames 0..{n - 1}"

