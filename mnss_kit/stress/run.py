"""The stress run: the given models and the baselines (bicubic, TAAU, FSR2) over every scenario, into one JSON document.

Per scenario and method: mean PSNR, SSIM, IF-SSIM, temporal error, the error inside disocclusion
masks (ghosting) and the frames until PSNR is back within 0.5 dB of steady state after each camera
cut and each scenario event (the end of a fast pan); the per-frame PSNR for the plots.  Per fault
(``scenarios.FAULTS``: one frame of NaN colour, one of Inf depth) and method: the frames until PSNR
is back within 0.5 dB of the clean run and whether every output stayed finite.  All methods
see the same frames in one evaluation loop (``mnss-kit eval``'s), so the numbers are paired.
At a scale S (``--scale``; default the data's, else the config's x2) the scenarios are rendered at
S and every model runs at it; a baseline that does not take S (FSR2 at a fractional one) is named
under ``not_covered``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import UserError
from ..fileio import portable_path
from ..eval.summary import RECOVERY_TOLERANCE_DB, frames_to_recover
from ..zoo import DEFAULT_MODEL
from .scenarios import BASELINES, DATA_CONFIG, FAULTS, MAX_RECOVERY_FRAMES, NOT_COVERED, SCENARIOS, Fault, fault_method, scenario

FORMAT, VERSION = "mnss-kit-stress", 1
METRIC_KEYS = ("psnr", "ssim", "if_ssim", "temporal_error", "disocclusion_psnr", "disocclusion_l1", "disoccluded_pixels")


@dataclass
class StressRequest:
    models: list[str] = field(default_factory=lambda: [DEFAULT_MODEL])  # checkpoint paths or shipped names
    work: Path = Path("runs/work")  # the rendered scenarios are kept here and reused
    data: Path | None = None  # already rendered scenario sequences (default: render DATA_CONFIG into work)
    max_frames: int | None = None
    crops_dir: Path | None = None
    progress: bool = True
    scale: int | float | None = None  # a parsed --scale (default: the data's, or the stress config's)


def run_stress(request: StressRequest) -> dict:
    """Evaluate ``request.models`` and the baselines on every scenario; returns the stress document."""
    from ..dataset import format as fmt
    from ..eval.loop import evaluate

    scale = stress_scale(request)
    # the models are refused before a render: one that cannot run at the scale names why
    methods, skipped = _methods(request.models, scale, "--scale" if request.scale else "the stress data")
    data = request.data or _render(scenario_config(scale), rendered_dir(request.work, scale), request.progress)
    result = evaluate(methods, data, scale=scale, max_frames=request.max_frames, crops_dir=request.crops_dir,
                      progress=request.progress)
    scenarios = {}
    for seq_dir in fmt.find_sequences(data):
        meta = fmt.read_meta(seq_dir)
        rows = [r for r in result["per_frame"] if r["sequence"] == seq_dir.name]
        scenarios[seq_dir.name] = scenario_entry(seq_dir.name, result["sequences"][seq_dir.name], rows,
                                                 [f.time for f in meta.frames], list(methods))
    missing = [s.name for s in SCENARIOS if s.name not in scenarios]
    faults = {}
    for fault in FAULTS:
        source = next((d for d in fmt.find_sequences(data) if d.name == fault.source), None)
        if source is None:
            missing.append(fault.name)
            continue
        clean = [r for r in result["per_frame"] if r["sequence"] == fault.source]
        faults[fault.name] = fault_entry(fault, clean, _run_fault(fault, methods, source, scale, request), list(methods))
    return {"format": FORMAT, "version": VERSION,
            "settings": {"data": portable_path(data), "models": list(request.models), "max_frames": request.max_frames,
                         "recovery_tolerance_db": RECOVERY_TOLERANCE_DB, "scale": scale},
            "methods": list(methods), "scenarios": scenarios, "faults": faults,
            "not_covered": {**NOT_COVERED, **skipped,
                            **{name: "scenario sequence missing from the data" for name in missing}}}


def _run_fault(fault: Fault, methods: dict, source: Path, scale: int | float, request: StressRequest) -> list[dict] | str:
    """The per-frame rows of every method on ``source`` with ``fault`` applied, or the error when a
    method's output was not finite (the evaluation refuses NaN / Inf outputs)."""
    from ..eval.loop import evaluate

    wrapped = {m: fault_method(f, fault) for m, f in methods.items()}
    try:
        return evaluate(wrapped, source, scale=scale, max_frames=request.max_frames, progress=request.progress)["per_frame"]
    except UserError as e:
        return str(e)


def fault_entry(fault: Fault, clean: list[dict], rows: list[dict] | str, methods: list[str]) -> dict:
    """One fault's document entry: per method the PSNR of the clean and the faulty run from the bad
    frame on, the frames after the bad one until the PSNR stays within the tolerance of the clean
    run's (None: never), whether every output was finite, and the verdict (recovered within
    ``MAX_RECOVERY_FRAMES`` with finite outputs)."""
    entry = {"case": fault.case, "source": fault.source, "buffers": list(fault.buffers), "value": str(fault.value),
             "bad_frame": fault.frame, "max_recovery_frames": MAX_RECOVERY_FRAMES, "methods": {}}
    for m in methods:
        before = [r["psnr"] for r in sorted((r for r in clean if r["method"] == m), key=lambda r: r["frame"])]
        if isinstance(rows, str):
            entry["methods"][m] = {"finite": False, "error": rows, "frames_to_recover": None, "passed": False}
            continue
        after = [r["psnr"] for r in sorted((r for r in rows if r["method"] == m), key=lambda r: r["frame"])]
        n = min(len(before), len(after))
        k = fault.frame
        finite = all(math.isfinite(v) for v in after[:n])
        recovered = next((j for j in range(n - k)
                          if all(before[i] - after[i] <= RECOVERY_TOLERANCE_DB for i in range(k + j, n))), None)
        entry["methods"][m] = {"finite": finite, "frames_to_recover": recovered,
                               "passed": finite and recovered is not None and recovered <= MAX_RECOVERY_FRAMES and k < n,
                               "clean_psnr": before[k:n], "fault_psnr": after[k:n]}
    return entry


def stress_scale(request: StressRequest) -> int | float:
    """The scale of the run: ``--data``'s (which must be ``--scale`` when both are given), else
    ``--scale``, else the stress config's."""
    from ..dataset import format as fmt
    from ..ops.scale import check_data_scale_is

    if request.data is None:
        return request.scale or _config_scale()
    data_scale = fmt.read_meta(fmt.find_sequences(request.data)[0]).scale
    check_data_scale_is(data_scale, request.scale, request.data)
    return data_scale


def _config_scale() -> int | float:
    from ..render.config import load_render_config

    return load_render_config(DATA_CONFIG).sequences[0].scale


def scenario_config(scale):
    """The scenarios at ``scale`` as ``mnss-kit render stress --scale S`` sets them, with Halton jitter
    for the grid-jittered ones where the grid pattern has no order (beyond x3, fractional scales):
    a per-sequence override, so the un-jittered scenario stays un-jittered."""
    from ..ops.jitter import GRID_SCALES
    from ..render.config import load_render_config

    as_written = load_render_config(DATA_CONFIG)
    if scale == _config_scale():
        return as_written
    halton = [f"{s.name}.jitter=halton" for s in as_written.sequences if s.jitter == "grid" and scale not in GRID_SCALES]
    return load_render_config(DATA_CONFIG, [f"scale={scale}", *halton])


def rendered_dir(work: Path, scale) -> Path:
    """Where the scenarios at ``scale`` are rendered: ``work/data/stress`` at the config's scale, as
    before, ``stress_x1.5`` beside it at another, so renders at two scales never share frames."""
    from ..ops.scale import scale_label

    name = DATA_CONFIG if scale == _config_scale() else f"{DATA_CONFIG}_{scale_label(scale)}"
    return work / "data" / name


def _render(config, out: Path, progress: bool) -> Path:
    from ..render.run import render_dataset

    render_dataset(config, out, progress=progress)  # skips frames already present
    return out


def _methods(models: list[str], scale, what: str) -> tuple[dict, dict[str, str]]:
    """``{label: method}`` for every model (by checkpoint name) set to run at ``scale`` (a one-line
    refusal of one that cannot, ``what`` naming where the scale came from) and the baselines that
    take it; and ``{baseline: why it was left out}``."""
    from ..eval.baselines import baseline_methods, baselines_at
    from ..eval.methods import model_method
    from ..model.checkpoint import load
    from ..model.families import run_at_scale
    from ..ops.scale import scale_label

    methods = {}
    for name in models:
        model, record = load(name)
        label = record.get("name") or Path(name).stem
        if label in methods or label in BASELINES:
            raise UserError(f"model '{name}': the name '{label}' is given twice or is a baseline's")
        run_at_scale(model, scale, what=what, where=f"model '{name}'")
        model.eval()
        methods[label] = model_method(model)
    baselines = baselines_at(scale, BASELINES)
    skipped = {b: f"the {b} baseline takes integer scales only so far: not run at {scale_label(scale)}"
               for b in BASELINES if b not in baselines}
    return {**methods, **baseline_methods(scale, baselines)}, skipped


def scenario_entry(name: str, info: dict, rows: list[dict], times: list[float], methods: list[str]) -> dict:
    """One scenario's document entry from eval's sequence info and per-frame rows."""
    n = info["frames"]
    known = scenario(name)
    event_frames = [next((i for i, t in enumerate(times[:n]) if t >= when - 1e-6), None) for when in (known.events if known else ())]
    events = sorted({*info["cuts"], *(i for i in event_frames if i is not None and 0 < i < n)})
    per_frame, stats = {}, {}
    for m in methods:
        psnrs = [r["psnr"] for r in sorted((r for r in rows if r["method"] == m), key=lambda r: r["frame"])]
        recovered = frames_to_recover(psnrs, events)
        per_frame[m] = psnrs
        stats[m] = {**{k: info["methods"][m].get(k) for k in METRIC_KEYS},
                    "warmup_frames": recovered[0], "frames_to_recover": recovered[1:]}
    return {"case": known.case if known else "(not a built-in scenario)", "frames": n, "cuts": info["cuts"],
            "events": events, "jitter_pattern": info["jitter_pattern"], "methods": stats, "per_frame_psnr": per_frame}
