"""The stress run: the given models and the baselines (bicubic, TAAU, FSR2) over every scenario, into one JSON document.

Per scenario and method: mean PSNR, SSIM, IF-SSIM, temporal error, the error inside disocclusion
masks (ghosting) and the frames until PSNR is back within 0.5 dB of steady state after each camera
cut and each scenario event (the end of a fast pan); the per-frame PSNR for the plots.  Per fault
(``scenarios.FAULTS``: one frame of NaN colour, one of Inf depth) and method: the frames until PSNR
is back within 0.5 dB of the clean run and whether every output stayed finite.  All methods
see the same frames in one evaluation loop (``mnss-kit eval``'s), so the numbers are paired.
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


def run_stress(request: StressRequest) -> dict:
    """Evaluate ``request.models`` and the baselines on every scenario; returns the stress document."""
    from ..dataset import format as fmt
    from ..eval.loop import evaluate

    data = request.data or _render(request.work / "data" / DATA_CONFIG, request.progress)
    methods, scale = _methods(request.models, data)
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
            "not_covered": {**NOT_COVERED, **{name: "scenario sequence missing from the data" for name in missing}}}


def _run_fault(fault: Fault, methods: dict, source: Path, scale: int, request: StressRequest) -> list[dict] | str:
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


def _render(out: Path, progress: bool) -> Path:
    from ..render.config import load_render_config
    from ..render.run import render_dataset

    render_dataset(load_render_config(DATA_CONFIG), out, progress=progress)  # skips frames already present
    return out


def _methods(models: list[str], data: Path) -> tuple[dict, int]:
    """``{label: method}`` for every model (by checkpoint name) and the baselines, and the scale."""
    from ..dataset import format as fmt
    from ..eval.baselines import baseline_methods
    from ..eval.methods import model_method
    from ..model.checkpoint import load

    scale = fmt.read_meta(fmt.find_sequences(data)[0]).scale
    methods = {}
    for name in models:
        model, record = load(name)
        label = record.get("name") or Path(name).stem
        if label in methods or label in BASELINES:
            raise UserError(f"model '{name}': the name '{label}' is given twice or is a baseline's")
        model.eval()
        methods[label] = model_method(model)
    return {**methods, **baseline_methods(scale, BASELINES)}, scale


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
