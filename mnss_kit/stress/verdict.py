"""Which method is best and worst where, read off the stress document's numbers, and the markdown table.

Ranks use the means of the scenario; a method with no value for a metric (no disocclusion in the
scenario, no event to recover from) is left out of that metric's ranking.  A recovery that never
came back within the tolerance ranks last.
"""

from __future__ import annotations

import math

from .scenarios import BASELINES

# metric key, label, True if higher is better
RANKED = (("psnr", "PSNR", True), ("if_ssim", "IF-SSIM", True), ("ssim", "SSIM", True),
          ("disocclusion_psnr", "disocclusion PSNR", True), ("recovery", "frames to recover", False))


def recovery_score(stats: dict) -> float | None:
    """The slowest recovery after an event (cut or pan), ``inf`` if one never recovered, None without events."""
    frames = stats["frames_to_recover"]
    if not frames:
        return None
    return max(math.inf if f is None else f for f in frames)


def metric_value(stats: dict, key: str) -> float | None:
    return recovery_score(stats) if key == "recovery" else stats.get(key)


def best_and_worst(methods: dict[str, dict], key: str, higher_is_better: bool) -> tuple[str, str] | None:
    """``(best, worst)`` method names for ``key``, or None when fewer than two methods have a value."""
    values = {m: metric_value(s, key) for m, s in methods.items()}
    values = {m: v for m, v in values.items() if v is not None and not (isinstance(v, float) and math.isnan(v))}
    if len(values) < 2 or len(set(values.values())) == 1:
        return None
    order = sorted(values, key=values.get, reverse=higher_is_better)
    return order[0], order[-1]


def verdicts(doc: dict) -> dict[str, dict[str, tuple[str, str]]]:
    """``{scenario: {metric label: (best, worst)}}``."""
    out = {}
    for name, entry in doc["scenarios"].items():
        ranks = {label: best_and_worst(entry["methods"], key, up) for key, label, up in RANKED}
        out[name] = {label: r for label, r in ranks.items() if r is not None}
    return out


# where a learned model must not fall below a baseline; the disocclusion PSNR is where trusting
# history leaves trails (figures crossing a wall), which the frame means can hide
LOSS_METRICS = (("psnr", "PSNR"), ("if_ssim", "IF-SSIM"), ("disocclusion_psnr", "disocclusion PSNR"))


def losses_to(doc: dict, method: str, reference: str) -> list[str]:
    """Scenarios where ``method`` has a lower PSNR, IF-SSIM or disocclusion PSNR than ``reference``, with the numbers."""
    lines = []
    for name, entry in doc["scenarios"].items():
        a, b = entry["methods"][method], entry["methods"][reference]
        for key, label in LOSS_METRICS:
            if a.get(key) is not None and b.get(key) is not None and a[key] < b[key]:
                lines.append(f"{name}: {label} {_fmt(key, a[key])} < {_fmt(key, b[key])}")
    return lines


def _fmt(key: str, value) -> str:
    if value is None:
        return "-"
    if key == "recovery":
        return "never" if value == math.inf else f"{value:.0f}"
    if key in ("psnr", "disocclusion_psnr"):
        return f"{value:.2f}"
    return f"{value:.4f}"


def _recovery_cell(stats: dict) -> str:
    frames = stats["frames_to_recover"]
    return ", ".join("never" if f is None else str(f) for f in frames) if frames else "-"


def scale_heading(doc: dict) -> str:
    """`` (x1.5)`` for a document whose settings record its scale (stress, size), else nothing
    (documents from before they did)."""
    from ..ops.scale import scale_label

    scale = doc.get("settings", {}).get("scale")
    return f" ({scale_label(scale)})" if scale is not None else ""


def markdown(doc: dict) -> str:
    """The stress table, the verdict per scenario, the learned models against each baseline, and what is not covered."""
    lines = [f"# Stress scenarios{scale_heading(doc)}", "", f"Methods: {', '.join(doc['methods'])} (same frames, one run).",
             f"Frames to recover: until PSNR is within {doc['settings']['recovery_tolerance_db']} dB of steady state "
             "after each camera cut or pan end (one number per event).", "",
             "| scenario | method | PSNR | SSIM | IF-SSIM | temporal error | disocclusion PSNR | frames to recover |",
             "|---|---|---|---|---|---|---|---|"]
    for name, entry in doc["scenarios"].items():
        for m, s in entry["methods"].items():
            lines.append(f"| {name} | {m} | {_fmt('psnr', s['psnr'])} | {_fmt('ssim', s['ssim'])} | "
                         f"{_fmt('if_ssim', s['if_ssim'])} | {_fmt('temporal_error', s['temporal_error'])} | "
                         f"{_fmt('disocclusion_psnr', s['disocclusion_psnr'])} | {_recovery_cell(s)} |")
    lines += ["", "## Best and worst per scenario", ""]
    for name, ranks in verdicts(doc).items():
        entry = doc["scenarios"][name]
        parts = [f"{label}: best {b} ({_fmt(key, metric_value(entry['methods'][b], key))}), "
                 f"worst {w} ({_fmt(key, metric_value(entry['methods'][w], key))})"
                 for key, label, _ in RANKED if label in ranks for b, w in [ranks[label]]]
        lines.append(f"- **{name}** ({entry['case']}): " + ("; ".join(parts) or "all methods equal"))
    learned = [m for m in doc["methods"] if m not in BASELINES]
    baselines = [(b, label) for b, label in (("taau", "TAAU"), ("fsr2", "FSR2"), ("bicubic", "bicubic")) if b in doc["methods"]]
    if baselines:
        lines += ["", "## Learned models against " + " and ".join(label for _, label in baselines), ""]
        for m in learned:
            for b, label in baselines:
                losses = losses_to(doc, m, b)
                lines.append(f"- {m} is below {label} in: " + ("; ".join(losses) if losses else "no scenario "
                                                               "(PSNR, IF-SSIM and disocclusion PSNR)"))
    if doc.get("faults"):
        lines += ["", "## Bad input frames", "",
                  f"One corrupted input frame; frames after it until PSNR stays within {doc['settings']['recovery_tolerance_db']} dB "
                  "of the clean run (pass: at most the fault's limit, and no NaN / Inf output).", "",
                  "| fault | method | frames to recover | finite outputs | PSNR clean / faulty (bad frame, +1, +2) | pass |",
                  "|---|---|---|---|---|---|"]
        for name, entry in doc["faults"].items():
            for m, s in entry["methods"].items():
                rec = "never" if s["frames_to_recover"] is None else str(s["frames_to_recover"])
                pairs = ", ".join(f"{a:.2f} / {b:.2f}" for a, b in zip(s.get("clean_psnr", [])[:3], s.get("fault_psnr", [])[:3]))
                lines.append(f"| {name} | {m} | {rec} | {'yes' if s['finite'] else 'no'} | {pairs or s.get('error', '-')} | "
                             f"{'yes' if s['passed'] else 'NO'} |")
    lines += ["", "## Not covered", ""]
    lines += [f"- {name}: {reason}" for name, reason in doc["not_covered"].items()] or ["- none"]
    return "\n".join(lines) + "\n"
