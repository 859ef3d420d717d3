"""The report stage's entry, :func:`build_report` (``mnss-kit report``): the report page,
``index.html``, its charts and the crops it shows, in one output directory.

Sections: per scale, a verdict (the smallest model that beats TAAU, the best within each device
budget), the bench records and charts (device milliseconds labelled as estimates, once, with why
fp32 and int8 share them); then per ``mnss-kit stress`` run one table per scenario with its
per-frame PSNR plot, its best and worst methods and its image crops (reference, every method and
their error maps, when ``mnss-kit stress`` wrote crops), and the cases the stress suite does not
cover; then one size ladder per ``mnss-kit size`` run, with its chart and the rung it chose.  Every
bench section, stress run and size ladder is headed by its scale (x2, x1.5), so runs at several
scales are told apart.  A section whose input was
not given says so and names the command that makes it.

Every chart is drawn here from the JSON it is given, as SVG inlined in the page: its text stays
text the browser lays out, so a test can measure that no two labels overlap.  The page has no
script and no external resource: the crops are PNGs copied next to it.
"""

from __future__ import annotations

import html
import re
import shutil
from pathlib import Path

from ..errors import UserError
from ..fileio import atomic_directory, atomic_write_text, check_format, read_json
from ..stress.scenarios import BASELINES

BENCH_FORMAT, STRESS_FORMAT, SIZE_FORMAT = ("mnss-kit-bench", 2), ("mnss-kit-stress", 1), ("mnss-kit-size", 1)
STYLE = """body{font-family:sans-serif;margin:2em;max-width:1200px;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1em}td,th{border:1px solid #bbb;padding:2px 6px;font-size:13px}
th{background:#eee}td.n{text-align:right;font-family:monospace}img{max-width:100%;margin:4px 0}
.note{color:#666;font-size:13px}.estimate{font-style:italic;color:#855}.verdict{background:#f4f8f0;padding:6px 10px}
.missing{color:#666;font-size:13px;border-left:3px solid #ccc;padding-left:8px}
div.chart svg{max-width:100%;height:auto;margin:4px 0}"""
DEFAULT_BUDGETS_MS = (4.0, 8.0)  # estimated frame ms: about a quarter and a half of a 60 fps frame
ESTIMATE_NOTE = ("Device milliseconds are estimates from the device profiles, not measurements: each model's default "
                 "GPU/NPU placement costed from its MACs and tensor sizes, with the NPU stage at the profile's int8 "
                 "throughput, the form a phone runs.  They depend on the architecture, not on the precision of the "
                 "numbers measured, so a model's fp32 and int8 rows show the same estimate.")
MISSING = {"bench": ("--bench", "`mnss-kit bench` (writes runs/bench/bench.json)"),
           "stress": ("--stress", "`mnss-kit stress` (writes runs/stress/stress.json)"),
           "size": ("--size", "`mnss-kit size --data DIR --target within:0.3` (writes runs/size/size.json)")}


def build_report(bench: Path | None, stresses: list[Path] | None, out: Path, overwrite: bool = False,
                 sizes: list[Path] | None = None, budgets_ms: tuple[float, ...] = DEFAULT_BUDGETS_MS) -> Path:
    """Write ``out/index.html`` and its charts from the bench, stress and size JSON; returns the page."""
    bench_doc = _load(bench, BENCH_FORMAT, "a bench file")
    stress_docs = [(p, _load(p, STRESS_FORMAT, "a stress file")) for p in stresses or []]
    size_docs = [(p, _load(p, SIZE_FORMAT, "a size file")) for p in sizes or []]
    with atomic_directory(out, overwrite=overwrite) as staging:
        body = []
        if bench_doc is not None:
            body += bench_sections(bench_doc, staging, budgets_ms)
        else:
            body += missing_section("Bench", "bench")
        for i, (path, doc) in enumerate(stress_docs):
            body += stress_section(doc, path.parent, staging, f"stress/{i}")
        if not stress_docs:
            body += missing_section("Stress scenarios", "stress")
        for i, (_, doc) in enumerate(size_docs):
            body += size_section(doc, staging / "size" / str(i), f"size/{i}")
        if not size_docs:
            body += missing_section("Model size", "size")
        page = ("<!doctype html><html lang=en><head><meta charset=utf-8><title>mnss-kit report</title>"
                f"<style>{STYLE}</style></head><body><h1>mnss-kit report</h1>\n" + "\n".join(body) + "\n</body></html>\n")
        atomic_write_text(staging / "index.html", page)
    return out / "index.html"


def missing_section(title: str, kind: str) -> list[str]:
    """A section whose input was not given: what is missing and the command that makes it."""
    flag, command = MISSING[kind]
    return [f"<h2>{_e(title)}</h2>",
            f"<p class=missing>Not in this report: {_e(flag)} was not given.  {_code(command)} makes it; "
            f"pass its JSON with {_e(flag)} FILE.</p>"]


def _code(text: str) -> str:
    """Backquoted spans of ``text`` as ``<code>``, the rest escaped."""
    return re.sub(r"`([^`]*)`", lambda m: f"<code>{m.group(1)}</code>", _e(text))


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


def inline_svg(path: Path, prefix: str) -> str:
    """The SVG file at ``path`` as an element for the page: XML prologue and metadata dropped, every id
    (and reference to one) prefixed, so that charts inlined side by side keep their own markers and clips."""
    text = path.read_text(encoding="utf-8")
    text = re.sub(r"<\?xml[^>]*\?>|<!DOCTYPE[^>]*>|<metadata>.*?</metadata>", "", text, flags=re.S)
    text = re.sub(r'\bid="([^"]+)"', lambda m: f'id="{prefix}-{m.group(1)}"', text)
    text = re.sub(r"url\(#([^)]+)\)", lambda m: f"url(#{prefix}-{m.group(1)})", text)
    text = re.sub(r'href="#([^"]+)"', lambda m: f'href="#{prefix}-{m.group(1)}"', text)
    return f'<div class=chart id="{_e(prefix)}" role=img aria-label="{_e(path.stem.replace("_", " "))}">{text.strip()}</div>'


def _charts(paths: list[Path], prefix: str) -> list[str]:
    return [inline_svg(p, f"{prefix}-{p.stem}") for p in paths]


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


def bench_sections(doc: dict, staging: Path, budgets_ms: tuple[float, ...] = DEFAULT_BUDGETS_MS) -> list[str]:
    """Per scale section: its verdict, its table and its charts (drawn here from the records)."""
    from ..bench.charts import write_section_charts
    from ..bench.run import caption, sections

    out = ["<h2>Bench</h2>"]
    note = bench_note(doc.get("note", ""))
    if note:
        out.append(f"<p class=note>{_e(note)}</p>")
    out.append(f"<p class=estimate>{_e(ESTIMATE_NOTE)}</p>")
    for name, section in sections(doc):
        charts = write_section_charts(section, staging / "bench" / name, ".svg")
        out += bench_section(name, caption(section["settings"]), section, _charts(charts, f"bench-{name}"), budgets_ms)
    return out


def bench_note(note: str) -> str:
    """The bench file's note without its clause on device milliseconds, which :data:`ESTIMATE_NOTE` states."""
    return "; ".join(c.strip() for c in note.split(";") if c.strip() and "device_ms" not in c)


def bench_section(name: str, title: str, section: dict, charts: list[str],
                  budgets_ms: tuple[float, ...] = DEFAULT_BUDGETS_MS) -> list[str]:
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
            f"<p class=verdict id=verdict-{_e(name)}><b>Verdict ({_e(name)}).</b> {_e(verdict(section, budgets_ms))}</p>",
            table(header, rows), *charts]


def verdict(section: dict, budgets_ms: tuple[float, ...] = DEFAULT_BUDGETS_MS) -> str:
    """One paragraph from a bench section's records: the smallest model that beats TAAU in mean PSNR,
    then the best model within each budget on each device profile.  Models are judged by their
    int8 records (what a phone runs) when there are any."""
    records = list(section["records"].values())
    models = [r for r in records if r["precision"] != "baseline"]
    judged = [r for r in models if r["precision"] == "int8"] or models
    if not judged:
        return "No model in this section."
    sentences = [_beats_taau(judged, next((r for r in records if r["precision"] == "baseline" and r["name"] == "taau"), None))]
    size = section["settings"].get("latency_size")
    at = f" at {size[0]}x{size[1]} output" if size else ""
    for device in section["settings"].get("devices", []):
        sentences.append(f"On {device} (estimated frame ms{at}): " + "; ".join(_best_within(judged, device, b) for b in budgets_ms) + ".")
    return " ".join(sentences)


def _label(r: dict) -> str:
    return f"{r['name']} ({r['precision']})"


def _beats_taau(judged: list[dict], taau: dict | None) -> str:
    if taau is None:
        return "No TAAU record here to judge the models against."
    better = sorted((r for r in judged if r["psnr"] > taau["psnr"]), key=lambda r: (r["macs_per_pixel"], -r["psnr"]))
    if not better:
        best = max(judged, key=lambda r: r["psnr"])
        return (f"No model beats TAAU ({taau['psnr']:.2f} dB mean PSNR); the closest, {_label(best)}, reaches "
                f"{best['psnr']:.2f} dB.")
    r = better[0]
    return (f"The smallest model that beats TAAU ({taau['psnr']:.2f} dB mean PSNR) is {_label(r)}: {r['psnr']:.2f} dB "
            f"(+{r['psnr'] - taau['psnr']:.2f} dB) at {r['macs_per_pixel']:.0f} MACs per output pixel.")


def _best_within(judged: list[dict], device: str, budget: float) -> str:
    timed = [(r, (r.get("device_ms") or {}).get(device)) for r in judged]
    timed = [(r, ms) for r, ms in timed if ms is not None]
    if not timed:
        return f"no estimate for {budget:g} ms"
    fits = [(r, ms) for r, ms in timed if ms <= budget]
    if not fits:
        r, ms = min(timed, key=lambda t: t[1])
        return f"nothing within {budget:g} ms (the cheapest, {_label(r)}, {ms:.2f} ms)"
    r, ms = max(fits, key=lambda t: (t[0]["psnr"], -t[1]))
    return f"within {budget:g} ms the best is {_label(r)}, {r['psnr']:.2f} dB at {ms:.2f} ms"


def stress_section(doc: dict, root: Path, staging: Path, rel: str = "stress/0") -> list[str]:
    """One ``mnss-kit stress`` run, headed by its scale; its plots and the crops of ``root/crops``
    go under ``staging/rel`` and its anchors start with ``rel``, so two runs on one page stay apart."""
    from ..stress.verdict import RANKED, losses_to, scale_heading, verdicts

    from ..stress.charts import write_plots

    prefix = rel.replace("/", "-")
    plots = write_plots(doc, staging / rel / "plots", ".svg")
    crops = _copy_images(root / "crops", staging, f"{rel}/crops")
    ranks = verdicts(doc)
    out = [f"<h2 id={_e(prefix)}>Stress scenarios{_e(scale_heading(doc))}</h2>",
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
        out += [f"<h3 id={_e(prefix)}-scenario-{_e(name)}>{_e(name)}</h3>", f"<p>{_e(entry['case'])}</p>", table(header, rows),
                f"<p>{verdict or 'all methods equal'}</p>",
                *_charts([plots[name]], prefix),
                *_images([p for p in crops if Path(p).name.startswith(f"{name}_")], "crop")]
    learned = [m for m in doc["methods"] if m not in BASELINES]
    if "taau" in doc["methods"]:
        out.append("<h3>Learned models against TAAU</h3><ul>" + "".join(
            f"<li>{_e(m)} below TAAU in: {_e('; '.join(losses_to(doc, m, 'taau')) or 'no scenario')}</li>" for m in learned)
            + "</ul>")
    out.append("<h3>Not covered</h3><ul>" + "".join(f"<li>{_e(k)}: {_e(v)}</li>" for k, v in doc["not_covered"].items())
               + "</ul>")
    return out


def size_section(doc: dict, staging: Path, rel: str) -> list[str]:
    """One ``mnss-kit size`` ladder, headed by its scale: its rows, the baselines, the choice and its chart."""
    from ..size.charts import verdict, write_chart
    from ..stress.verdict import scale_heading

    staging.mkdir(parents=True, exist_ok=True)
    chart = write_chart(doc, staging / "size.svg")
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
    return [f"<h2>Model size{_e(scale_heading(doc))} for held-out {_e(scene)}</h2>",
            f"<p>{'Chosen: <b>' + _e(chosen) + '</b>' if chosen else 'No rung meets the targets'} "
            f"(targets: {_e(targets)}; {_e(settings['steps'])} training steps per rung on "
            f"{_e(len(settings['train_sequences']))} sequence(s) of the scene).</p>",
            table(header, rows), *_charts([chart], rel.replace("/", "-"))]
