"""The report page: ``index.html`` and the PNGs it shows, in one output directory.

Sections: the bench records and charts (device milliseconds labelled as estimates), then one
table per stress scenario with its per-frame PSNR plot, its best and worst methods and its image
crops (reference, every method and their error maps, when ``mnss-kit stress`` wrote crops), and
the cases the stress suite does not cover; then one size ladder per ``mnss-kit size`` run, with
its chart and the rung it chose.  The page has no script and no external resource:
every image is a PNG copied next to it.
"""

from __future__ import annotations

import html
import shutil
from pathlib import Path

from ..errors import UserError
from ..fileio import atomic_directory, atomic_write_text, check_format, read_json

BENCH_FORMAT, STRESS_FORMAT, SIZE_FORMAT = ("mnss-kit-bench", 2), ("mnss-kit-stress", 1), ("mnss-kit-size", 1)
STYLE = """body{font-family:sans-serif;margin:2em;max-width:1200px;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1em}td,th{border:1px solid #bbb;padding:2px 6px;font-size:13px}
th{background:#eee}td.n{text-align:right;font-family:monospace}img{max-width:100%;margin:4px 0}
.note{color:#666;font-size:13px}.estimate{font-style:italic;color:#855}"""


def build_report(bench: Path | None, stress: Path | None, out: Path, overwrite: bool = False,
                 sizes: list[Path] | None = None) -> Path:
    """Write ``out/index.html`` and its images from the bench, stress and size JSON; returns the page."""
    docs = {"bench": _load(bench, BENCH_FORMAT, "a bench file"), "stress": _load(stress, STRESS_FORMAT, "a stress file")}
    size_docs = [(p, _load(p, SIZE_FORMAT, "a size file")) for p in sizes or []]
    with atomic_directory(out, overwrite=overwrite) as staging:
        body = []
        if docs["bench"] is not None:
            body += bench_sections(docs["bench"], bench.parent / "charts", staging)
        if docs["stress"] is not None:
            body += stress_section(docs["stress"], stress.parent, staging)
        for i, (path, doc) in enumerate(size_docs):
            body += size_section(doc, path, staging / "size" / str(i), f"size/{i}")
        page = ("<!doctype html><html lang=en><head><meta charset=utf-8><title>mnss-kit report</title>"
                f"<style>{STYLE}</style></head><body><h1>mnss-kit report</h1>\n" + "\n".join(body) + "\n</body></html>\n")
        atomic_write_text(staging / "index.html", page)
    return out / "index.html"


def _load(path: Path | None, fmt: tuple[str, int], what: str) -> dict | None:
    if path is None:
        return None
    if not path.is_file():
        raise UserError(f"{path}: no such file")
    doc = read_json(path)
    check_format(doc, path, fmt[0], "version", fmt[1], what)
    return doc


def _copy_images(src: Path, staging: Path, rel: str) -> list[str]:
    """Copy the PNGs of ``src`` into ``staging/rel``; their paths relative to the page."""
    found = sorted(src.glob("*.png")) if src.is_dir() else []
    (staging / rel).mkdir(parents=True, exist_ok=True)
    for p in found:
        shutil.copyfile(p, staging / rel / p.name)
    return [f"{rel}/{p.name}" for p in found]


def _e(value) -> str:
    return html.escape(str(value))


def _num(value, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def table(header: list[str], rows: list[list[str]]) -> str:
    """An HTML table; cells are already escaped or formatted."""
    head = "".join(f"<th>{h}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td class=n>{c}</td>" if c[:1].isdigit() or c[:1] == "-" else f"<td>{c}</td>"
                                    for c in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _images(paths: list[str], alt: str) -> list[str]:
    return [f'<div><img src="{_e(p)}" alt="{_e(alt)} {_e(Path(p).stem)}"></div>' for p in paths]


def bench_sections(doc: dict, charts: Path, staging: Path) -> list[str]:
    """One bench table and its charts per scale section (charts from ``charts/<section>/``)."""
    from ..bench.run import caption, sections

    out = ["<h2>Bench</h2>", f"<p class=note>{_e(doc.get('note', ''))}</p>",
           "<p class=estimate>Device milliseconds are estimates from the device profiles, not measurements.</p>"]
    for name, section in sections(doc):
        out += bench_section(name, caption(section["settings"]), section, _copy_images(charts / name, staging, f"bench/{name}"))
    return out


def bench_section(name: str, title: str, section: dict, charts: list[str]) -> list[str]:
    devices = section["settings"].get("devices", [])
    header = ["model", "family", "precision", "PSNR", "SSIM", "IF-SSIM", "MACs/pixel", "CPU ms (xnnpack)"]
    header += [f'<span class=estimate>{_e(d)} ms (estimate)</span>' for d in devices]
    rows = []
    for r in section["records"].values():
        cpu = (r.get("cpu_ms") or {}).get("xnnpack")
        rows.append([_e(r["name"]), _e(r["family"]), _e(r["precision"]), _num(r["psnr"]), _num(r["ssim"], 4),
                     _num(r["if_ssim"], 4), _num(r["macs_per_pixel"], 0), _num(cpu)]
                    + [_num((r.get("device_ms") or {}).get(d)) for d in devices])
    return [f"<h3 id=bench-{_e(name)}>{_e(title)}</h3>",
            table(header, rows), *_images(charts, "bench chart")]


def stress_section(doc: dict, root: Path, staging: Path) -> list[str]:
    from ..stress.verdict import RANKED, losses_to, verdicts

    plots = _copy_images(root / "plots", staging, "stress/plots")
    crops = _copy_images(root / "crops", staging, "stress/crops")
    ranks = verdicts(doc)
    out = ["<h2>Stress scenarios</h2>",
           f"<p class=note>Frames to recover: until PSNR is within {_e(doc['settings']['recovery_tolerance_db'])} dB "
           "of steady state after each camera cut or pan end.</p>"]
    header = ["method", "PSNR", "SSIM", "IF-SSIM", "temporal error", "disocclusion PSNR", "frames to recover"]
    for name, entry in doc["scenarios"].items():
        rows = [[_e(m), _num(s["psnr"]), _num(s["ssim"], 4), _num(s["if_ssim"], 4), _num(s["temporal_error"], 4),
                 _num(s["disocclusion_psnr"]),
                 _e(", ".join("never" if f is None else str(f) for f in s["frames_to_recover"]) or "-")]
                for m, s in entry["methods"].items()]
        verdict = "; ".join(f"{label}: best {_e(b)}, worst {_e(w)}" for _, label, _ in RANKED
                            if label in ranks[name] for b, w in [ranks[name][label]])
        out += [f"<h3 id={_e(name)}>{_e(name)}</h3>", f"<p>{_e(entry['case'])}</p>", table(header, rows),
                f"<p>{verdict or 'all methods equal'}</p>",
                *_images([p for p in plots if Path(p).stem == name], "per-frame PSNR"),
                *_images([p for p in crops if Path(p).name.startswith(f"{name}_")], "crop")]
    learned = [m for m in doc["methods"] if m not in ("bicubic", "taau")]
    if "taau" in doc["methods"]:
        out.append("<h3>Learned models against TAAU</h3><ul>" + "".join(
            f"<li>{_e(m)} below TAAU in: {_e('; '.join(losses_to(doc, m, 'taau')) or 'no scenario')}</li>" for m in learned)
            + "</ul>")
    out.append("<h3>Not covered</h3><ul>" + "".join(f"<li>{_e(k)}: {_e(v)}</li>" for k, v in doc["not_covered"].items())
               + "</ul>")
    return out


def size_section(doc: dict, path: Path, staging: Path, rel: str) -> list[str]:
    """One ``mnss-kit size`` ladder: its rows, the baselines, the choice and its chart."""
    from ..size.charts import verdict

    staging.mkdir(parents=True, exist_ok=True)
    chart = path.parent / "size.png"
    images = []
    if chart.is_file():
        shutil.copyfile(chart, staging / "size.png")
        images = [f"{rel}/size.png"]
    settings, chosen = doc["settings"], (doc.get("choice") or {}).get("config")
    scene = ", ".join(Path(t).name for t in settings["test_sequences"])
    header = ["config", "MACs/pixel", "params", "PSNR", "SSIM", "IF-SSIM"]
    header += [f"<span class=estimate>{_e(d)} ms (estimate)</span>" for d in settings["devices"]] + ["verdict"]
    rows = [[_e(r["config"]), _num(r["macs_per_pixel"], 0), _e(r["params"]), _num(r["psnr"]), _num(r["ssim"], 4),
             _num(r["if_ssim"], 4), *[_num(r["device_ms"].get(d)) for d in settings["devices"]],
             f"<b>{_e(verdict(r, chosen))}</b>" if r["config"] == chosen else _e(verdict(r, chosen))]
            for r in sorted(doc["rows"].values(), key=lambda r: r["macs_per_pixel"])]
    rows += [[_e(f"{name} (baseline)"), "0", "0", _num(q["psnr"]), _num(q["ssim"], 4), _num(q["if_ssim"], 4),
              *["-" for _ in settings["devices"]], "reference"] for name, q in doc["baselines"].items()]
    targets = ", ".join(doc.get("targets") or []) + (f"; budget {doc['budget']}" if doc.get("budget") else "")
    return [f"<h2>Model size for held-out {_e(scene)}</h2>",
            f"<p>{'Chosen: <b>' + _e(chosen) + '</b>' if chosen else 'No rung meets the targets'} "
            f"(targets: {_e(targets)}; {_e(settings['steps'])} training steps per rung on "
            f"{_e(len(settings['train_sequences']))} sequence(s) of the scene).</p>",
            table(header, rows), *_images(images, "size ladder")]
