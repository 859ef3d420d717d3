"""Charts from a bench document, one folder per scale (``x2/``, ``x4/``): quality against cost,
fp32 and int8 points, baselines as reference lines, the Pareto front marked; and the int8 loss per
model."""

from __future__ import annotations

from pathlib import Path

from ..fileio import atomic_output_path
from .pareto import pareto_front

MARKERS = {"fp32": "o", "int8": "s"}
CPU_RUNTIME = "xnnpack"  # the LiteRT default path, whose int8/fp32 ratio the latency chart shows


def _cpu_ms(record: dict) -> float | None:
    return (record.get("cpu_ms") or {}).get(CPU_RUNTIME)


def chart_specs(section: dict) -> list[tuple[str, str, str, callable]]:
    """``(file stem, x label, y key, x of a record)`` of every chart."""
    specs = [("psnr_vs_macs", "MACs per output pixel", "psnr", lambda r: r["macs_per_pixel"]),
             ("psnr_vs_cpu_ms", f"NPU-stage CPU latency, {CPU_RUNTIME} (ms, median)", "psnr", _cpu_ms),
             ("if_ssim_vs_macs", "MACs per output pixel", "if_ssim", lambda r: r["macs_per_pixel"])]
    for device in section["settings"]["devices"]:
        specs.append((f"psnr_vs_ms_{device}", f"estimated frame ms on {device} (estimate)", "psnr",
                      lambda r, d=device: r["device_ms"].get(d)))
    return specs


def write_charts(doc: dict, out_dir: Path) -> list[Path]:
    """Every chart of every scale section of a bench document, as PNG under ``out_dir/<section>/``."""
    from .run import sections

    return [p for name, section in sections(doc) for p in write_section_charts(section, out_dir / name)]


def write_section_charts(section: dict, out_dir: Path) -> list[Path]:
    """Every chart of :func:`chart_specs` and the int8-loss chart of one scale section."""
    import matplotlib

    matplotlib.use("Agg")
    out_dir.mkdir(parents=True, exist_ok=True)
    from .run import caption

    records = list(section["records"].values())
    suffix = f" ({caption(section['settings'])})"
    written = [_scatter(records, stem, xlabel, key, x_of, out_dir / f"{stem}.png", suffix)
               for stem, xlabel, key, x_of in chart_specs(section)]
    written.append(_int8_loss(records, out_dir / "int8_loss.png", suffix))
    return written


def _scatter(records, stem, xlabel, key, x_of, path: Path, suffix: str) -> Path:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    models = [r for r in records if r["precision"] != "baseline" and x_of(r) is not None]
    for r in models:
        ax.scatter(x_of(r), r[key], marker=MARKERS[r["precision"]], s=40)
        below = r["precision"] == "int8"  # int8 labels under the point: a model's two points often nearly coincide
        ax.annotate(f"{r['name']} {r['precision']}", (x_of(r), r[key]), fontsize=7, xytext=(4, -9 if below else 3),
                    textcoords="offset points")
    front = [models[i] for i in pareto_front([(x_of(r), r[key]) for r in models])]
    if front:
        ax.plot([x_of(r) for r in front], [r[key] for r in front], "k--", lw=1)
        ax.scatter([x_of(r) for r in front], [r[key] for r in front], s=140, facecolors="none", edgecolors="black",
                   label="Pareto front")
    for r in (r for r in records if r["precision"] == "baseline"):
        ax.axhline(r[key], color="grey", lw=0.8, ls=":")
        ax.annotate(r["name"], (ax.get_xlim()[0], r[key]), fontsize=7, color="grey", xytext=(2, 2), textcoords="offset points")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(key.upper().replace("_", "-") if key != "psnr" else "PSNR (dB)")
    ax.set_title(f"{stem.replace('_', ' ')}{suffix}", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    with atomic_output_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


def _int8_loss(records, path: Path, suffix: str) -> Path:
    import matplotlib.pyplot as plt

    pairs = {}
    for r in records:
        if r["precision"] in ("fp32", "int8"):
            pairs.setdefault(r["name"], {})[r["precision"]] = r
    names = sorted(n for n, p in pairs.items() if len(p) == 2)
    loss = [pairs[n]["int8"]["psnr"] - pairs[n]["fp32"]["psnr"] for n in names]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.bar(names, loss)
    ax.axhline(0.0, color="black", lw=0.8)
    ax.set_ylabel("int8 - fp32 PSNR (dB)")
    ax.set_title(f"int8 loss per model{suffix}", fontsize=9)
    fig.tight_layout()
    with atomic_output_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path
