"""The report page from small synthetic bench, stress and size documents, opened in headless Chromium:
every image loads, no error is raised, and no two texts of a chart overlap where the browser lays
them out."""

import html
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from mnss_kit.cli import main
from mnss_kit.eval.crops import write_crops
from mnss_kit.fileio import atomic_write_json
from mnss_kit.ops.scale import scale_label
from mnss_kit.report.run import build_report
from mnss_kit.stress.scenarios import NOT_COVERED

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
# Recorded into the DOM once the page has loaded: which images decoded, and every error the page raised
# (script errors, failed resources, console.error calls).
PROBE = """<script>
window.__errors = [];
window.addEventListener('error', e => window.__errors.push(String(e.message || (e.target && e.target.src))), true);
const realError = console.error; console.error = (...a) => { window.__errors.push(a.join(' ')); realError(...a); };
// every chart's texts (point labels, legend, ticks, titles) as the browser laid them out, and the pairs
// whose boxes intersect by more than half a pixel each way
const chartTexts = div => [...div.querySelectorAll('text')].map(t => [t.textContent.trim(), t.getBoundingClientRect()])
  .filter(([s, r]) => s && r.width > 0 && r.height > 0);
const overlapping = boxes => boxes.flatMap(([s, a], i) => boxes.slice(i + 1).filter(([, b]) =>
  Math.min(a.right, b.right) - Math.max(a.left, b.left) > 0.5 && Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top) > 0.5)
  .map(([t]) => [s, t]));
window.addEventListener('load', () => {
  const out = document.createElement('pre'); out.id = 'probe';
  out.textContent = JSON.stringify({images: [...document.images].map(i => [i.getAttribute('src'), i.complete && i.naturalWidth > 0]),
                                    charts: [...document.querySelectorAll('div.chart')].map(d => {
                                      const boxes = chartTexts(d); return [d.id, boxes.map(([s]) => s), overlapping(boxes)]; }),
                                    errors: window.__errors});
  document.body.appendChild(out);
});
</script>"""


def _record(name, family, precision, psnr, macs, ms=None):
    return {"name": name, "family": family, "precision": precision, "psnr": psnr, "ssim": 0.9, "if_ssim": 0.95 + psnr / 1000,
            "temporal_error": 0.01, "macs_per_pixel": macs, "params": 10, "cpu_ms": {"xnnpack": macs / 2000} if macs else None,
            "device_ms": {"phone_a": ms, "phone_b": 2.5 * ms} if macs else {}}


# names that start alike at nearly the same cost and quality, and a TAAU line through the markers:
# what made the charts' labels overlap
MODELS = [("ntaau_x2", "ntaau", 31.75, 2872, 3.1), ("ntaau_x2_fast", "ntaau", 31.62, 1429, 2.9),
          ("ntaau_x2_tiny", "ntaau", 31.21, 1058, 2.8), ("mnss_x2", "mnss", 30.9, 7414, 6.4),
          ("fusesr_x2_hybrid", "fusesr", 31.19, 9000, 7.0)]


def _bench(root, scales=(2,)):
    records = [_record("bicubic", "baseline", "baseline", 29.1, 0.0), _record("taau", "baseline", "baseline", 31.2, 0.0)]
    for name, family, psnr, macs, ms in MODELS:
        records += [_record(name, family, "fp32", psnr, macs, ms), _record(name, family, "int8", psnr - 0.04, macs, ms)]
    section = {"records": {f"{r['name']}/{r['precision']}": r for r in records},
               "settings": {"quick": True, "devices": ["phone_a", "phone_b"], "scale": 2, "data": "tiny_test",
                            "latency_size": [320, 180]}}
    benches = {scale_label(s): {**section, "settings": {**section["settings"], "scale": s}} for s in scales}
    note = ("quality on held-out frames; cpu_ms medians of interleaved runs on a shared machine (compare ratios within one "
            "run); device_ms are estimates from the device profiles, not measurements")
    doc = {"format": "mnss-kit-bench", "version": 2, "note": note, "benches": benches}
    atomic_write_json(root / "bench.json", doc)
    return root / "bench.json"


def _stress(root, scale=None):
    stats = {"psnr": 30.0, "ssim": 0.9, "if_ssim": 0.95, "temporal_error": 0.01, "disocclusion_psnr": 20.0,
             "disocclusion_l1": 0.05, "disoccluded_pixels": 10, "warmup_frames": 1, "frames_to_recover": [2]}
    methods = {"m": stats, "bicubic": dict(stats, psnr=27.0), "taau": dict(stats, psnr=29.0, frames_to_recover=[None])}
    settings = {"recovery_tolerance_db": 0.5, **({"scale": scale} if scale else {})}
    doc = {"format": "mnss-kit-stress", "version": 1, "settings": settings, "methods": list(methods),
           "not_covered": dict(NOT_COVERED),
           "scenarios": {"camera_cut": {"case": "camera cut <history>", "frames": 3, "cuts": [1], "events": [1],
                                        "jitter_pattern": "grid", "methods": methods,
                                        "per_frame_psnr": {m: [25.0, 20.0, 29.0] for m in methods}}}}
    rng = np.random.default_rng(0)
    reference = rng.random((32, 32, 3))
    write_crops(root / "crops", "camera_cut", 2, reference, {m: np.clip(reference + 0.05 * rng.standard_normal((32, 32, 3)), 0, 1)
                                                            for m in methods})
    atomic_write_json(root / "stress.json", doc)
    return root / "stress.json"


def _size(root, scale=None):
    def rung(config, macs, psnr, misses):
        return {"config": config, "macs_per_pixel": macs, "params": 100, "psnr": psnr, "ssim": 0.9, "if_ssim": 0.95,
                "device_ms": {"phone_a": macs / 1000}, "steps": 10, "misses": misses}

    doc = {"format": "mnss-kit-size", "version": 1, "targets": ["within:0.3"], "budget": None,
           "settings": {"devices": ["phone_a"], "steps": 10, "train_sequences": ["a", "b"], "test_sequences": ["scene/held"],
                        **({"scale": scale} if scale else {})},
           "rows": {"tiny": rung("tiny", 1700, 30.0, ["PSNR 1.00 dB below big (allowed 0.3)"]), "big": rung("big", 7400, 31.0, [])},
           "baselines": {"taau": {"psnr": 29.5, "ssim": 0.9, "if_ssim": 0.95}}, "choice": {"config": "big"}}
    (root / "size").mkdir()
    atomic_write_json(root / "size" / "size.json", doc)
    return root / "size" / "size.json"


def _open(page, tmp_path, extra_body=""):
    """The probe's record and Chromium's console lines for ``page``, loaded with the probe script
    (and ``extra_body`` appended to the page)."""
    probe = page.with_name("probe.html")
    probe.write_text(page.read_text().replace("<head>", "<head>" + PROBE, 1).replace("</body>", extra_body + "</body>", 1))
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'chromium'}",
           "--window-size=1280,2000",
           "--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000", "--dump-dom", probe.as_uri()]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    probe.unlink()
    found = re.search(r'<pre id="probe">(.*?)</pre>', done.stdout, re.S)
    assert found, f"the page did not finish loading: {done.stderr[-2000:]}"
    record = json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))
    console = [line for line in done.stderr.splitlines() if ":CONSOLE" in line]
    return record, console


needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium package (scripts/setup.sh installs it)")


@needs_chromium
def test_report_loads_in_chromium_with_every_image_and_no_console_error(tmp_path):
    page = build_report(_bench(tmp_path), [_stress(tmp_path)], tmp_path / "report", sizes=[_size(tmp_path)])
    text = page.read_text()
    assert "(estimate)" in text and "camera cut &lt;history&gt;" in text and "hud_overlay" in text
    assert "Model size for held-out held" in text and "Chosen: <b>big</b>" in text and "1.00 dB below big" in text
    record, console = _open(page, tmp_path)
    sources = [src for src, _ in record["images"]]
    assert any(src.startswith("stress/0/crops/camera_cut_") for src in sources)
    assert all(ok for _, ok in record["images"]), record["images"]
    charts = [chart_id for chart_id, _, _ in record["charts"]]
    assert "bench-x2-psnr_vs_macs" in charts and "stress-0-camera_cut" in charts and "size-0-size" in charts
    assert record["errors"] == [] and console == [], (record["errors"], console)

    # the same check sees a missing image: it is not a check that always passes
    crop = next(src for src in sources if src.startswith("stress/0/crops/"))
    (tmp_path / "report" / crop).unlink()
    record, _ = _open(page, tmp_path)
    assert dict(record["images"])[crop] is False
    assert record["errors"]


# two labels drawn at nearly the same place: what the overlap check must catch
OVERLAPPING_CHART = """<div class=chart id=overlap-check><svg width="200" height="100" xmlns="http://www.w3.org/2000/svg">
<text x="20" y="50" style="font: 12px 'DejaVu Sans'">ntaau_x2</text>
<text x="30" y="54" style="font: 12px 'DejaVu Sans'">ntaau_x2_fast</text></svg></div>"""


@needs_chromium
def test_no_two_chart_labels_overlap_in_chromium(tmp_path):
    page = build_report(_bench(tmp_path), [_stress(tmp_path)], tmp_path / "report", sizes=[_size(tmp_path)])
    record, _ = _open(page, tmp_path)
    charts = {chart_id: (texts, overlaps) for chart_id, texts, overlaps in record["charts"]}
    assert len(charts) == 6 + 1 + 1  # the bench's six of x2, one stress scenario, one size ladder
    for chart_id, (texts, overlaps) in charts.items():
        assert overlaps == [], f"{chart_id}: overlapping labels {overlaps}"
    # every model is named once per quality chart, with the baselines in its legend
    texts = charts["bench-x2-psnr_vs_ms_phone_a"][0]
    assert all(texts.count(name) == 1 for name, *_ in MODELS) and "taau" in texts and "bicubic" in texts
    assert {"tiny", "big"} <= set(charts["size-0-size"][0])

    # the same check sees two overlapping labels: it is not a check that always passes
    record, _ = _open(page, tmp_path, OVERLAPPING_CHART)
    assert dict((c, o) for c, _, o in record["charts"])["overlap-check"] == [["ntaau_x2", "ntaau_x2_fast"]]


def test_verdict_names_the_smallest_model_beating_taau_and_the_best_within_each_budget(tmp_path):
    page = build_report(_bench(tmp_path), None, tmp_path / "report", budgets_ms=(3.0, 8.0))
    text = html.unescape(re.sub(r"<[^>]+>", "", page.read_text()))
    verdict = next(line for line in text.splitlines() if line.startswith("Verdict (x2)."))
    # int8 records are judged: ntaau_x2_tiny (31.17 dB) falls below TAAU (31.20), ntaau_x2_fast (31.58) beats it
    assert ("The smallest model that beats TAAU (31.20 dB mean PSNR) is ntaau_x2_fast (int8): 31.58 dB (+0.38 dB) "
            "at 1429 MACs per output pixel.") in verdict
    assert ("On phone_a (estimated frame ms at 320x180 output): within 3 ms the best is ntaau_x2_fast (int8), 31.58 dB "
            "at 2.90 ms; within 8 ms the best is ntaau_x2 (int8), 31.71 dB at 3.10 ms.") in verdict
    assert "On phone_b (estimated frame ms at 320x180 output): nothing within 3 ms (the cheapest, ntaau_x2_tiny (int8), 7.00 ms)" in verdict


def test_report_states_the_estimates_once_and_each_section_not_given(tmp_path):
    page = build_report(_bench(tmp_path), None, tmp_path / "report")
    text = html.unescape(re.sub(r"<[^>]+>", "", page.read_text()))
    assert text.count("estimates from the device profiles") == 1
    assert "fp32 and int8 rows show the same estimate" in text
    assert "Not in this report: --stress was not given.  mnss-kit stress (writes runs/stress/stress.json) makes it" in text
    assert "Not in this report: --size was not given." in text and "--bench was not given" not in text


def test_report_command_names_a_wrong_file_and_needs_an_input(tmp_path, capsys):
    assert main(["report", "--out", str(tmp_path / "r")]) == 2
    other = tmp_path / "other.json"
    other.write_text('{"format": "something-else", "version": 1}')
    assert main(["report", "--bench", str(other), "--out", str(tmp_path / "r")]) == 2
    assert "other.json: not a bench file" in capsys.readouterr().err
    assert main(["report", "--bench", str(_bench(tmp_path)), "--budget-ms", "4", "0", "--out", str(tmp_path / "r")]) == 2
    assert "--budget-ms must be positive, got 4 0" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_results_at_several_scales_are_headed_by_their_scale(tmp_path, capsys):
    for scale in (2, 1.5):
        (tmp_path / scale_label(scale)).mkdir()
    stresses = [_stress(tmp_path / scale_label(scale), scale) for scale in (2, 1.5)]
    out = tmp_path / "report"
    assert main(["report", "--bench", str(_bench(tmp_path, scales=(2, 1.5))), "--stress", str(stresses[0]),
                 "--stress", str(stresses[1]), "--size", str(_size(tmp_path, 1.5)), "--out", str(out)]) == 0
    page = (out / "index.html").read_text()
    text = html.unescape(re.sub(r"<[^>]+>", "", page))
    assert text.index("Verdict (x1.5).") < text.index("Verdict (x2).")  # the smaller scale first
    assert "Stress scenarios (x2)" in text and "Stress scenarios (x1.5)" in text
    assert "Model size (x1.5) for held-out held" in text
    # each run keeps its own anchors, plots and crops
    ids = re.findall(r"<h[23] id=([^\s>]+)>", page) + re.findall(r'<div class=chart id="([^"]+)"', page)
    assert len(ids) == len(set(ids))
    assert {"stress-0", "stress-1", "stress-0-scenario-camera_cut", "stress-1-camera_cut"} <= set(ids)
    assert all((out / f"stress/{i}/crops").glob("camera_cut_*.png") for i in (0, 1))
