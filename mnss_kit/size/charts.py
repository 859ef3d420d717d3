"""The ladder of a size document as a Markdown table and a chart: quality against MACs per pixel,
the baselines as reference lines, the targets drawn, the chosen rung ringed."""

from __future__ import annotations

from pathlib import Path


def verdict(row: dict, chosen: str | None) -> str:
    """``chosen``, ``meets targets`` or the reasons the rung was passed over (the table and the report)."""
    if row["config"] == chosen:
        return "chosen"
    return "; ".join(row.get("misses") or []) or "meets targets"


def markdown(doc: dict) -> str:
    from ..ops.scale import scale_label

    rows = sorted(doc["rows"].values(), key=lambda r: r["macs_per_pixel"])
    devices = doc["settings"]["devices"]
    chosen = (doc.get("choice") or {}).get("config")
    head = ["config", "MACs/px", "params", "PSNR", "SSIM", "IF-SSIM", *[f"{d} ms (est.)" for d in devices], "steps", "verdict"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        text = verdict(r, chosen)
        text = f"**{text}**" if r["config"] == chosen else text
        steps = f"{r['steps']}" + (" (time cap)" if r.get("stopped") == "time_budget" else "")
        ms = [f"{r['device_ms'][d]:.2f}" if r["device_ms"].get(d) is not None else "-" for d in devices]
        psnr = f"{r['psnr']:.2f}" + (" (" + ", ".join(f"{x['psnr']:.2f}" for x in r["seeds"]) + ")" if r.get("seeds") else "")
        lines.append(f"| {r['config']} | {r['macs_per_pixel']:.0f} | {r['params']} | {psnr} | {r['ssim']:.4f} | "
                     f"{r['if_ssim']:.4f} | " + " | ".join(ms) + f" | {steps} | {text} |")
    for name, q in doc["baselines"].items():
        lines.append(f"| {name} (baseline) | 0 | 0 | {q['psnr']:.2f} | {q['ssim']:.4f} | {q['if_ssim']:.4f} | "
                     + " | ".join("-" for _ in devices) + " | - | reference |")
    s = doc["settings"]
    targets = ", ".join(doc.get("targets") or []) + (f"; budget {doc['budget']}" if doc.get("budget") else "")
    summary = (f"Chosen: **{chosen}**." if chosen else "No rung meets the targets.") + f" Targets: {targets}."
    facts = (f"At {scale_label(s['scale'])}: trained {s['steps']} steps per rung on {len(s['train_sequences'])} sequence(s); evaluated on "
             f"{len(s['test_sequences'])} held-out sequence(s) never trained on ({', '.join(Path(t).name for t in s['test_sequences'])})"
             + (f", first {s['max_frames']} frames each" if s.get("max_frames") else "")
             + f". Device milliseconds are estimates at {s['output_size'][0]}x{s['output_size'][1]} output."
             + seed_note(rows) + detail_note(rows, s))
    return "\n".join([summary, "", facts, "", *lines]) + "\n"


def detail_note(rows: list[dict], settings: dict) -> str:
    """With ``CONFIG+detail`` rungs: what they are, and each one's gain over its CONFIG rung seed by
    seed (the same trained steering with and without the branch, so seed noise cancels)."""
    from .run import DETAIL, base_config

    by_name = {r["config"]: r for r in rows}
    gains = []
    for row in (r for r in rows if base_config(r["config"]) != r["config"] and base_config(r["config"]) in by_name):
        base = by_name[base_config(row["config"])]
        pairs = zip(row.get("seeds") or [row], base.get("seeds") or [base])
        gains.append(f"{row['config']} " + ", ".join(f"{a['psnr'] - b['psnr']:+.2f}" for a, b in pairs) + " dB")
    if not gains:
        return ""
    return (f" A CONFIG{DETAIL} rung is CONFIG's with the detail branch of finetune --detail (CONFIG{DETAIL}N: of "
            f"width N) fitted on the training "
            f"sequences ({settings.get('detail_minutes', 0):g} min); its gain over CONFIG, seed by seed: {'; '.join(gains)}.")


def seed_note(rows: list[dict]) -> str:
    """With several seeds per rung: what the PSNR cells hold, and whether the seeds of one rung differ
    by more than the rungs' means do (then the choice is within seed noise)."""
    seeded = [r for r in rows if r.get("seeds")]
    if not seeded:
        return ""
    spread = max(max(x["psnr"] for x in r["seeds"]) - min(x["psnr"] for x in r["seeds"]) for r in seeded)
    gap = max(r["psnr"] for r in rows) - min(r["psnr"] for r in rows)
    note = (f" Each rung trained with {len(seeded[0]['seeds'])} seeds: PSNR is their mean, each seed's in brackets; "
            f"the chosen rung's best seed is the checkpoint exported. The seeds of one rung differ by up to {spread:.2f} dB, "
            f"the rungs' means by {gap:.2f} dB")
    return note + (": the choice is within seed noise." if spread > gap else ".")


def write_chart(doc: dict, path: Path, title: str = "") -> Path:
    """PSNR and IF-SSIM against MACs per output pixel for every rung, as one PNG (or SVG, by the
    suffix of ``path``).  Rung names are placed so that no two labels overlap
    (:func:`mnss_kit.bench.charts.place_labels`); lines and marks are named in a legend below."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..bench.charts import place_labels, save_figure

    rows = sorted(doc["rows"].values(), key=lambda r: r["macs_per_pixel"])
    chosen = (doc.get("choice") or {}).get("config")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6))
    for ax, key, label in ((axes[0], "psnr", "PSNR (dB)"), (axes[1], "if_ssim", "IF-SSIM")):
        x = [r["macs_per_pixel"] for r in rows]
        ax.plot(x, [r[key] for r in rows], "o-", color="tab:blue", label="ladder rungs")
        for r in rows:
            if r["config"] == chosen:
                ax.scatter([r["macs_per_pixel"]], [r[key]], s=220, facecolors="none", edgecolors="tab:red", linewidths=2, label="chosen")
        lines = []
        for (name, q), style in zip(doc["baselines"].items(), ("--", ":")):
            ax.axhline(q[key], color="gray", linestyle=style, label=name)
            lines.append(q[key])
        for line, text in _target_lines(doc, rows, key):
            ax.axhline(line, color="tab:green", linestyle="-.", label=text)
            lines.append(line)
        ax.set_xscale("log")
        ax.margins(x=0.2, y=0.2)  # room for the rung names inside the plot
        ax.set_xlabel("MACs per output pixel")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=min(len(labels), 5), frameon=False)
    fig.suptitle(title or "model size ladder on held-out sequences")
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    for ax, key in ((axes[0], "psnr"), (axes[1], "if_ssim")):
        points = [(r["macs_per_pixel"], r[key]) for r in rows]
        place_labels(ax, [(r["config"], xy, "black") for r, xy in zip(rows, points)], points,
                     [q[key] for q in doc["baselines"].values()] + [v for v, _ in _target_lines(doc, rows, key)], fontsize=8)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def _target_lines(doc: dict, rows: list[dict], key: str) -> list[tuple[float, str]]:
    """Horizontal lines the targets put on the ``key`` axis."""
    largest = max(rows, key=lambda r: r["macs_per_pixel"])
    lines = []
    for text in doc.get("targets") or []:
        kind, _, value = text.partition(":")
        if kind == "within" and key == "psnr":
            lines.append((largest["psnr"] - float(value), f"target {text}"))
        elif kind == "taau" and key == "psnr" and "taau" in doc["baselines"]:
            lines.append((doc["baselines"]["taau"]["psnr"] + float(value), f"target {text}"))
        elif kind == key:
            lines.append((float(value), f"target {text}"))
    return lines
