"""Charts from a bench document, one folder per scale (``x2/``, ``x4/``): quality against cost,
fp32 and int8 points, baselines as reference lines, the Pareto front marked; and the int8 loss per
model.

Labels never overlap: :func:`place_labels` tries positions around each point and keeps the first
whose box (measured by matplotlib's renderer, padded for a browser's slightly different text
metrics) meets no other label and no marker; baselines and marker shapes are named in a legend
outside the plot.  A chart saved as ``.svg`` keeps its text as ``<text>`` elements, so a browser
lays the labels out (``mnss-kit report`` inlines them and its test measures them there).
"""

from __future__ import annotations

from pathlib import Path

from ..fileio import atomic_output_path
from .pareto import pareto_front

MARKERS = {"fp32": "o", "int8": "s"}
BASELINE_STYLES = (":", "--", "-.")
CPU_RUNTIME = "xnnpack"  # the LiteRT default path, whose int8/fp32 ratio the latency chart shows
LABEL_PAD_PT = 2.5  # room kept around every label box: a browser's text boxes are a little taller than matplotlib's
MARKER_RADIUS_PT = 6.0  # half the Pareto ring (size 140 points^2): the box a label keeps off a point
# label positions tried around a point, nearest first: (dx, dy) in points and the text's alignment
DIRECTIONS = ((1, 0.6, "left", "bottom"), (1, -0.6, "left", "top"), (-1, 0.6, "right", "bottom"),
              (-1, -0.6, "right", "top"), (0, 1.2, "center", "bottom"), (0, -1.2, "center", "top"),
              (1, 0, "left", "center"), (-1, 0, "right", "center"))
DISTANCES_PT = (9, 15, 22, 32, 44)


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


def write_charts(doc: dict, out_dir: Path, suffix: str = ".png") -> list[Path]:
    """Every chart of every scale section of a bench document under ``out_dir/<section>/``, as PNG
    (or ``.svg``)."""
    from .run import sections

    return [p for name, section in sections(doc) for p in write_section_charts(section, out_dir / name, suffix)]


def write_section_charts(section: dict, out_dir: Path, suffix: str = ".png") -> list[Path]:
    """Every chart of :func:`chart_specs` and the int8-loss chart of one scale section."""
    import matplotlib

    matplotlib.use("Agg")
    out_dir.mkdir(parents=True, exist_ok=True)
    from .run import caption

    records = list(section["records"].values())
    title = f" ({caption(section['settings'])})"
    written = [_scatter(records, stem, xlabel, key, x_of, out_dir / f"{stem}{suffix}", title)
               for stem, xlabel, key, x_of in chart_specs(section)]
    written.append(_int8_loss(records, out_dir / f"int8_loss{suffix}", title))
    return written


def save_figure(fig, path: Path, dpi: int) -> Path:
    """``fig`` as PNG or SVG by ``path``'s suffix; SVG text stays text (``<text>`` elements)."""
    import matplotlib

    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": path.stem}), atomic_output_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    return path


def place_labels(ax, labels: list[tuple[str, tuple[float, float], str]], points: list[tuple[float, float]],
                 lines: list[float] = (), fontsize: float = 7) -> list:
    """Annotate ``(text, (x, y), colour)`` in data coordinates where no label box meets another, a
    marker at ``points`` or a horizontal line at ``lines`` (data coordinates); a label moved away
    from its point gets a thin leader line.  Call after the axes' limits and layout are final."""
    from matplotlib.transforms import Bbox

    fig = ax.figure
    renderer = fig.canvas.get_renderer()
    px = fig.dpi / 72.0
    area = ax.get_window_extent(renderer)
    radius = MARKER_RADIUS_PT * px
    taken = [Bbox.from_extents(x - radius, y - radius, x + radius, y + radius)
             for x, y in ax.transData.transform(points)] if points else []
    taken += [Bbox.from_extents(area.x0, y - px, area.x1, y + px) for _, y in ax.transData.transform([(0, v) for v in lines])]
    ax.set_autoscale_on(False)  # the leader lines must not move the limits the boxes were measured in
    placed = []
    for i, (text, anchor, colour) in enumerate(labels):
        note = ax.annotate(text, anchor, fontsize=fontsize, color=colour, textcoords="offset points", xytext=(0, 0),
                           gid=f"label-{i}", annotation_clip=False)
        best = None
        for distance in DISTANCES_PT:
            for dx, dy, ha, va in DIRECTIONS:
                note.set(ha=ha, va=va)
                note.xyann = (dx * distance, dy * distance)
                box = note.get_window_extent(renderer).padded(LABEL_PAD_PT * px)
                inside = area.containsx(box.x0) and area.containsx(box.x1) and area.containsy(box.y0) and area.containsy(box.y1)
                clashes = sum(box.overlaps(t) for t in taken) + (0 if inside else 100)
                if best is None or clashes < best[0]:
                    best = (clashes, distance, dx, dy, ha, va, box)
                if clashes == 0:
                    break
            if best[0] == 0:
                break
        _, distance, dx, dy, ha, va, box = best
        note.set(ha=ha, va=va)
        note.xyann = (dx * distance, dy * distance)
        taken.append(box)
        if distance > DISTANCES_PT[0]:
            _leader(ax, anchor, box, colour)
        placed.append(note)
    return placed


def _leader(ax, anchor: tuple[float, float], box, colour: str) -> None:
    """A thin line from a point to the nearest edge of its moved label."""
    x, y = ax.transData.transform(anchor)
    ex, ey = min(max(x, box.x0), box.x1), min(max(y, box.y0), box.y1)
    (lx, ly), (tx, ty) = ax.transData.inverted().transform([(x, y), (ex, ey)])
    ax.plot([lx, tx], [ly, ty], color=colour, lw=0.5, alpha=0.7)


def model_colours(names: list[str]) -> dict[str, str]:
    """One colour per model name, in first-seen order."""
    palette = [f"C{i}" for i in range(10)]
    order = list(dict.fromkeys(names))
    return {name: palette[i % len(palette)] for i, name in enumerate(order)}


def _scatter(records, stem, xlabel, key, x_of, path: Path, title: str) -> Path:
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    models = [r for r in records if r["precision"] != "baseline" and x_of(r) is not None]
    colours = model_colours([r["name"] for r in models])
    for r in models:
        ax.scatter(x_of(r), r[key], marker=MARKERS[r["precision"]], s=40, color=colours[r["name"]])
    front = [models[i] for i in pareto_front([(x_of(r), r[key]) for r in models])]
    handles = [Line2D([], [], marker=m, ls="", color="black", label=p) for p, m in MARKERS.items()]
    if front:
        ax.plot([x_of(r) for r in front], [r[key] for r in front], "k--", lw=1)
        handles.append(ax.scatter([x_of(r) for r in front], [r[key] for r in front], s=140, facecolors="none",
                                  edgecolors="black", label="Pareto front"))
    for r, style in zip((r for r in records if r["precision"] == "baseline"), BASELINE_STYLES * 4):
        handles.append(ax.axhline(r[key], color="grey", lw=0.9, ls=style, label=r["name"]))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(key.upper().replace("_", "-") if key != "psnr" else "PSNR (dB)")
    ax.set_title(f"{stem.replace('_', ' ')}{title}", fontsize=9)
    ax.margins(x=0.15, y=0.15)  # room for the labels inside the plot
    ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    fig.tight_layout()
    place_labels(ax, _one_label_per_model(models, x_of, key, colours), [(x_of(r), r[key]) for r in models],
                 [r[key] for r in records if r["precision"] == "baseline"])
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def _one_label_per_model(models: list[dict], x_of, key: str, colours: dict[str, str]) -> list:
    """A model's name once, at its int8 point (the one a phone runs), else at its fp32 point; colour
    and marker shape tell its two points apart."""
    anchors = {}
    for r in sorted(models, key=lambda r: r["precision"] == "int8"):  # int8 last: it wins
        anchors[r["name"]] = (x_of(r), r[key])
    return [(name, xy, colours[name]) for name, xy in anchors.items()]


def _int8_loss(records, path: Path, title: str) -> Path:
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
    ax.set_title(f"int8 loss per model{title}", fontsize=9)
    if len(names) > 4:  # long names side by side collide: slant them
        plt.setp(ax.get_xticklabels(), rotation=30, ha="right")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
