"""The bench run: every model in fp32 and int8 and the baselines, quality against cost, into one JSON.

One bench file holds one section per upscaling factor (``benches["x2"]``, ``benches["x4"]``):
each compares the models of that scale on one held-out set at it, with the baselines on the same
frames.  By default every scale that has a shipped checkpoint or a trained run is benched.
Per model (shipped checkpoints, and every ``runs/*/model.pt`` a ladder config was trained into):

* quality on the held-out frames (``mnss-kit eval``'s loop): fp32, and int8 with the NPU stage
  quantized on the calibration data and run in LiteRT's reference kernels;
* int8 through the deployment path: the bundle ``mnss-kit export`` writes, run by the emulator
  (``emulated_psnr``, ``emulated_frame_s``: the desktop emulator's time, not a phone's);
* cost: MACs per output pixel, parameters, the NPU stage's median CPU latency in LiteRT and ONNX
  Runtime with int8 and fp32 timed side by side (:mod:`.latency`), and the estimated frame
  milliseconds on every shipped device profile (``mnss-kit split``; estimates).

The JSON is rewritten atomically after every model, so a killed run continues with the records
it has; a section made with other settings (another data set, ``--quick`` or not) is not reused,
and sections of scales this run does not bench are kept.
"""

from __future__ import annotations

import logging
import statistics
from dataclasses import asdict, dataclass
from pathlib import Path

from ..errors import UserError
from ..fileio import atomic_write_json, read_json
from .records import record_key, record_problems

log = logging.getLogger(__name__)
FORMAT, VERSION = "mnss-kit-bench", 2
BASELINES = ("bicubic", "taau")
NOTE = ("quality on held-out frames; cpu_ms medians of interleaved runs on a shared machine (compare ratios "
        "within one run); device_ms are estimates from the device profiles, not measurements")


@dataclass(frozen=True)
class Settings:
    """What the numbers of one section depend on; a section made with other settings is not resumed."""

    quick: bool
    scale: int  # upscaling factor of the data and of every model benched
    data: str  # the held-out data set (a render config name, or a directory)
    max_frames: int | None  # per sequence
    latency_size: tuple[int, int]  # HR (w, h) the NPU stage is timed at
    latency_repeats: int
    emulated_frames: int  # per sequence through the bundle
    devices: tuple[str, ...]


QUICK = dict(data="tiny_test", max_frames=8, latency_size=(320, 180), latency_repeats=3, emulated_frames=3)
# the full run's quality is on the first 30 frames of each held-out sequence (half of test_x2's),
# which keeps a bench of the shipped models within 45 minutes on a 2-core CPU; the charts say so
FULL = dict(data="test_x2", max_frames=30, latency_size=(1280, 720), latency_repeats=10, emulated_frames=8)


@dataclass
class BenchRequest:
    out: Path = Path("runs/bench/bench.json")
    work: Path = Path("runs/work")  # rendered data sets and bundles, reused between runs
    models: list[str] | None = None  # checkpoint paths or shipped names (default: module docstring)
    data: Path | None = None  # held-out data set (default: render the settings' config into ``work``)
    quick: bool = False
    scale: int | None = None  # only this scale (default: the data's scale, or every scale with a model)
    devices: list[str] | None = None  # device profiles (default: every shipped one)
    progress: bool = True


def section_name(scale: int) -> str:
    return f"x{scale}"


def default_models(runs: Path = Path("runs")) -> list[str]:
    """The shipped checkpoints, then every trained run under ``runs``."""
    from ..model.checkpoint import shipped_names

    return [*shipped_names(), *(sorted(str(p) for p in runs.glob("*/model.pt")) if runs.is_dir() else [])]


def model_scale(name: str) -> int | float:
    from ..model.checkpoint import read_record
    from ..ops.scale import parse_scale

    return parse_scale(read_record(name)[0]["scale"])  # 2 stays 2; a quality mode such as 1.5 stays 1.5


def models_by_scale(request: BenchRequest) -> dict[int, list[str]]:
    """The models of every scale benched: the requested models (or the default ones) grouped by
    their scale; limited to the data's scale with ``--data`` and to ``--scale`` when given."""
    only = bench_scale(request)
    grouped: dict[int, list[str]] = {}
    for name in request.models or default_models():
        grouped.setdefault(model_scale(name), []).append(name)
    if only is None:
        return dict(sorted(grouped.items())) or {2: []}
    for scale, names in grouped.items():
        if scale != only and request.models:
            raise UserError(f"{names[0]} is x{scale} but the bench is x{only} (leave out --scale and --data to bench every scale)")
        if scale != only:
            log.info("bench at x%s only: %s (x%s) left out", only, ", ".join(names), scale)
    return {only: grouped.get(only, [])}


def scale_overrides(scale: int | float) -> list[str]:
    """Render overrides that make a built-in x2 data config ``scale``: Halton jitter beyond x3 and at
    a fractional scale (the grid pattern exists for x2 and x3)."""
    from ..ops.jitter import GRID_SCALES

    return [] if scale == 2 else [f"scale={scale}", *(["jitter=halton"] if scale not in GRID_SCALES else [])]


def held_out_config(quick: bool, scale: int) -> tuple[str, list[str]]:
    """The built-in held-out render config at ``scale`` and its overrides."""
    from ..config import CONFIG_DIR

    if quick:
        return QUICK["data"], scale_overrides(scale)
    name = FULL["data"] if scale == 2 else f"test_x{scale}"
    if not (CONFIG_DIR / "data" / f"{name}.yaml").is_file():
        raise UserError(f"no built-in held-out data set at x{scale} (mnss_kit/configs/data/{name}.yaml): give --data")
    return name, [f"frames={FULL['max_frames']}"]  # only the frames the bench measures are rendered


def bench_scale(request: BenchRequest) -> int | None:
    """The one scale benched: ``request.scale``, which must be the data's when both are given, else
    the data's; None when neither is given (every scale)."""
    if request.data is None:
        return request.scale
    from ..dataset import format as fmt
    from ..ops.scale import check_data_scale_is

    data_scale = fmt.read_meta(fmt.find_sequences(request.data)[0]).scale
    check_data_scale_is(data_scale, request.scale, request.data)
    return data_scale


def run_bench(request: BenchRequest) -> dict:
    """Bench every model of ``request`` at its scale; returns the bench document (also written to
    ``request.out``)."""
    from ..split.device import device_names

    devices = tuple(request.devices or device_names())
    plan = models_by_scale(request)
    doc = _read_doc(request.out)
    steps = [(scale, name) for scale, names in plan.items() for name in [None, *names]]  # None: the baselines
    if request.progress:
        from tqdm import tqdm

        steps = tqdm(steps, desc="bench", unit="model")
    prepared: dict[int, tuple] = {}
    for scale, name in steps:
        if scale not in prepared:
            prepared[scale] = _prepare_section(doc, request, scale, devices)
        records, settings, data, calibration = prepared[scale]
        if name is None:
            new = [] if all(f"{b}/baseline" in records for b in BASELINES) else baseline_records(data, settings)
        elif _benched(records, name):
            continue
        else:
            new = model_records(name, data, calibration, settings, request.work)
        for record in new:
            problems = record_problems(record)
            if problems:
                raise RuntimeError(f"bench record {record_key(record)}: {problems[0]}")
            records[record_key(record)] = record
        atomic_write_json(request.out, doc)
    return doc


def _prepare_section(doc: dict, request: BenchRequest, scale: int, devices: tuple[str, ...]) -> tuple[dict, Settings, Path, Path]:
    """The records of the section of ``scale`` in ``doc`` (resumed when its settings match), its
    settings, its held-out data and its calibration data (both rendered into ``request.work`` once)."""
    preset = QUICK if request.quick else FULL
    config, overrides = held_out_config(request.quick, scale) if request.data is None else (None, [])
    settings = Settings(quick=request.quick, scale=scale, devices=devices,
                        data=str(request.data) if request.data else " ".join([config, *overrides]),
                        max_frames=preset["max_frames"], latency_size=preset["latency_size"],
                        latency_repeats=preset["latency_repeats"], emulated_frames=preset["emulated_frames"])
    name, plain = section_name(scale), _plain(asdict(settings))
    kept = doc["benches"].get(name)
    if kept is not None and kept.get("settings") == plain:
        log.info("resuming %s of %s: %d record(s) kept", name, request.out, len(kept["records"]))
    else:
        if kept is not None:
            log.info("%s of %s was made with other settings; starting it afresh", name, request.out)
        doc["benches"][name] = {"settings": plain, "records": {}}
    data = request.data or _rendered(config, overrides, request.work / "data", request.progress)
    return doc["benches"][name]["records"], settings, data, _calibration_data(request.work / "data", scale, request.progress)


def _read_doc(out: Path) -> dict:
    """The bench file at ``out``, or a fresh document."""
    if not out.is_file():
        return {"format": FORMAT, "version": VERSION, "note": NOTE, "benches": {}}
    doc = read_json(out)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT or doc.get("version") != VERSION:
        raise UserError(f"{out}: not a bench file of this version (remove it or give another --out)")
    return doc


def caption(settings: dict) -> str:
    """What one section's numbers are of, for its charts and the report: scale, data, frames."""
    frames = f", first {settings['max_frames']} frames per sequence" if settings.get("max_frames") else ""
    return f"x{settings['scale']}, {settings['data'].split()[0]}{frames}" + (", quick run" if settings.get("quick") else "")


def sections(doc: dict) -> list[tuple[str, dict]]:
    """``(name, section)`` of every scale in a bench document, smallest scale first."""
    return sorted(doc["benches"].items(), key=lambda item: item[1]["settings"]["scale"])


def _plain(value):
    """Settings as JSON holds them (tuples become lists), so a reread file compares equal."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def model_label(name: str) -> str:
    """A checkpoint's name in records and tables: its run directory for ``runs/<name>/model.pt``."""
    path = Path(name)
    return path.parent.name if path.name == "model.pt" else path.stem


def _rendered(config: str, overrides: list[str], root: Path, progress: bool) -> Path:
    """The render config ``config`` (with ``overrides``) rendered into ``root`` (once; reused afterwards)."""
    from ..render.config import load_render_config
    from ..render.run import render_dataset

    out = root / "_".join([config, *(o.replace("=", "") for o in overrides)])  # e.g. test_x2_frames30
    render_dataset(load_render_config(config, overrides or None), out, progress=progress)  # skips frames already present
    return out


def _calibration_data(root: Path, scale: int, progress: bool) -> Path:
    from ..quantize.run import render_calibration_data

    out = root / ("calibration" if scale == 2 else f"calibration_x{scale}")
    # scale= too: render_calibration_data appends its own scale override after ours
    return render_calibration_data(out, progress, with_reference=False, overrides=scale_overrides(scale), scale=scale)


def baseline_records(data: Path, settings: Settings) -> list[dict]:
    from ..dataset import format as fmt
    from ..eval.baselines import baseline_methods
    from ..eval.loop import evaluate

    scale = fmt.read_meta(fmt.find_sequences(data)[0]).scale
    result = evaluate(baseline_methods(scale), data, scale=scale, max_frames=settings.max_frames, progress=False)
    return [{"name": name, "family": "baseline", "precision": "baseline", **quality(result["methods"][name]),
             "macs_per_pixel": 0.0, "params": 0, "cpu_ms": None, "device_ms": {}} for name in BASELINES]


def _benched(records: dict, name: str) -> bool:
    """Whether ``records`` hold both precisions of checkpoint ``name`` as its file is now: a model
    retrained under the same name is benched again."""
    from ..model import checkpoint

    digest = checkpoint.digest(name)
    return all(records.get(f"{model_label(name)}/{p}", {}).get("checkpoint_sha256") == digest for p in ("fp32", "int8"))


def model_records(name: str, data: Path, calibration: Path, settings: Settings, work: Path) -> list[dict]:
    """The fp32 and int8 records of one checkpoint."""
    from ..eval.methods import model_method
    from ..eval.loop import evaluate
    from ..model.checkpoint import digest, load
    from ..model.families import family_of
    from .latency import npu_latency

    model, record = load(name)
    model.eval()
    label = model_label(name)
    family = family_of(model)
    methods = {"fp32": model_method(model), "int8": model_method(int8_at_size(model, calibration, data, label))}
    result = evaluate(methods, data, scale=model.scale, max_frames=settings.max_frames, progress=False)
    latency = npu_latency(model, settings.latency_size, settings.latency_repeats)
    cost = model_cost(model, settings.devices, settings.latency_size)
    common = {"name": label, "family": family.name, "source": str(name), "checkpoint_sha256": digest(name), **cost}
    fp32 = {**common, "precision": "fp32", **quality(result["methods"]["fp32"]),
            "cpu_ms": {rt: t["fp32_ms"] for rt, t in latency.items()}}
    int8 = {**common, "precision": "int8", **quality(result["methods"]["int8"]),
            "cpu_ms": {rt: t["int8_ms"] for rt, t in latency.items()},
            "cpu_fp32_over_int8": {rt: t["fp32_over_int8"] for rt, t in latency.items()},
            # ONNX Runtime's default x86 int8 path, timed beside ort-cpu: faster, CPU-dependent results
            "ort_u8_path_ms": latency["ort-cpu"]["int8_u8_ms"],
            **emulated(name, data, calibration, settings, work / "bundles" / label)}
    return [fp32, int8]


def int8_at_size(model, calibration: Path, data: Path, name: str):
    """A copy of ``model`` whose NPU stage is quantized (minmax) on ``calibration`` and runs in
    LiteRT's reference kernels at ``data``'s HR size."""
    from ..model.families import family_of, npu_module
    from ..quantize.run import CALIBRATION_SAMPLES, calibration_samples, int8_model, open_data
    from ..quantize.stage import QuantizeOptions, quantize_module

    samples = calibration_samples(model, open_data(calibration, model.scale, family=family_of(model)), CALIBRATION_SAMPLES)
    art = at_size(quantize_module(npu_module(model), samples, QuantizeOptions(), name=name), npu_module(model), data, model)
    return int8_model(model, art)


def at_size(art, module, data: Path, model=None):
    """``art`` (calibrated at the calibration data's size) retargeted to ``data``'s HR size: the int8
    graph's tensors have fixed shapes, the scales and zero points stay.  With ``model`` the stage's
    input shapes are traced from it (a net at LR rounded up to even keeps no ratio to the HR size)."""
    from types import SimpleNamespace

    from ..dataset import format as fmt
    from ..export.npu_stage import retarget
    from ..model.families import npu_input_shapes
    from ..quantize.tflite_writer import to_tflite

    meta = fmt.read_meta(fmt.find_sequences(data)[0])
    hr_size = tuple(meta.hr_size)  # lr * s at an integer scale; the data's display size at a fractional one
    graph = retarget(art.graph, module, hr_size, npu_input_shapes(model, hr_size) if model is not None else None)
    return SimpleNamespace(graph=graph, tflite=to_tflite(graph), report=art.report)


def quality(summary: dict) -> dict:
    """The quality keys of one method's summary in an eval result (bench and size records)."""
    return {k: summary[k] for k in ("psnr", "ssim", "if_ssim", "temporal_error", "phase_offset")}


def quality_table(result: dict, methods) -> dict:
    """:func:`quality` of each of ``methods`` in an eval result, over all frames and per sequence."""
    return {"methods": {m: quality(result["methods"][m]) for m in methods},
            "sequences": {seq: {m: quality(entry["methods"][m]) for m in methods} for seq, entry in result["sequences"].items()}}


def model_cost(model, devices: tuple[str, ...], hr_size: tuple[int, int]) -> dict:
    """A model's cost from its architecture: MACs per output pixel (all, and on the NPU), parameters
    and the estimated frame ms on each device profile (:func:`device_estimates`)."""
    from ..model.macs import count_macs

    macs = count_macs(model)
    plans = default_placements(model, devices, hr_size)
    return {"macs_per_pixel": macs.total, "npu_macs_per_pixel": macs.by_placement("npu"), "params": macs.params,
            "device_ms": {d: plan.estimated_frame_ms for d, plan in plans.items()},
            "boundary_bytes_per_pixel": {d: boundary_bytes_per_pixel(plan) for d, plan in plans.items()}}


def device_estimates(model, devices: tuple[str, ...], hr_size: tuple[int, int]) -> dict[str, float]:
    """Estimated frame milliseconds of the default placement on each device profile (estimates)."""
    return {d: plan.estimated_frame_ms for d, plan in default_placements(model, devices, hr_size).items()}


def default_placements(model, devices: tuple[str, ...], hr_size: tuple[int, int]) -> dict:
    """``{device: Placement}``: the default GPU/NPU placement on each device profile."""
    from ..split.device import load_device
    from ..split.dataflow import trace_model
    from ..split.plan import plan_flow

    flow = trace_model(model)
    return {d: plan_flow(flow, load_device(d), "default", hr_size) for d in devices}


def boundary_bytes_per_pixel(plan) -> dict[str, float]:
    """Bytes a frame moves into the NPU (``in``) and out of it (``out``) per output pixel: the traffic
    the GPU<->NPU handoffs carry, 0 for a placement all on the GPU."""
    pixels = plan.resolution[0] * plan.resolution[1]
    moved = {"in": 0, "out": 0}
    for tensor in plan.boundary:
        moved["in" if tensor.direction == "gpu->npu" else "out"] += tensor.bytes_per_frame
    return {way: nbytes / pixels for way, nbytes in moved.items()}


def export_at_size(name: str, data: Path, calibration: Path, bundle: Path) -> Path:
    """``mnss-kit export`` of ``name`` into ``bundle`` at ``data``'s HR size, calibrated on ``calibration``."""
    from ..dataset import format as fmt
    from ..export.run import ExportRequest, export

    meta = fmt.read_meta(fmt.find_sequences(data)[0])
    w, h = meta.hr_size  # the data's display size (at a fractional scale not always round(lr * s))
    export(ExportRequest(model=name, out=bundle, resolution=f"{w}x{h}", data=calibration, overwrite=True, progress=False))
    return bundle


def emulated(name: str, data: Path, calibration: Path, settings: Settings, bundle: Path) -> dict:
    """The int8 model through its bundle and the emulator: mean PSNR of the displayed frames and the
    median emulated seconds per frame (the desktop emulator's time)."""
    from ..emulate.frame_loop import Emulator
    from ..emulate.run import run_dataset

    export_at_size(name, data, calibration, bundle)
    report = run_dataset(Emulator(bundle), data, frames=settings.emulated_frames)
    summaries = [s["summary"] for s in report["sequences"].values()]
    return {"emulated_psnr": statistics.fmean(s["mean_psnr_db"] for s in summaries if "mean_psnr_db" in s),
            "emulated_frame_s": statistics.median(s["median_seconds_total"] for s in summaries),
            "emulated_frames": settings.emulated_frames}
