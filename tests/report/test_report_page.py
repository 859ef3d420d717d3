"""The report page from small synthetic bench and stress documents, opened in headless Chromium."""

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from mnss_kit.cli import main
from mnss_kit.eval.crops import write_crops
from mnss_kit.fileio import atomic_write_json
from mnss_kit.report.page import build_report
from mnss_kit.stress.charts import write_plots
from mnss_kit.stress.scenarios import NOT_COVERED

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
# Recorded into the DOM once the page has loaded: which images decoded, and every error the page raised
# (script errors, failed resources, console.error calls).
PROBE = """<script>
window.__errors = [];
window.addEventListener('error', e => window.__errors.push(String(e.message || (e.target && e.target.src))), true);
const realError = console.error; console.error = (...a) => { window.__errors.push(a.join(' ')); realError(...a); };
window.addEventListener('load', () => {
  const out = document.createElement('pre'); out.id = 'probe';
  out.textContent = JSON.stringify({images: [...document.images].map(i => [i.getAttribute('src'), i.complete && i.naturalWidth > 0]),
                                    errors: window.__errors});
  document.body.appendChild(out);
});
</script>"""


def _record(name, family, precision, psnr, macs):
    return {"name": name, "family": family, "precision": precision, "psnr": psnr, "ssim": 0.9, "if_ssim": 0.95,
            "temporal_error": 0.01, "macs_per_pixel": macs, "params": 10, "cpu_ms": {"xnnpack": 1.5} if macs else None,
            "device_ms": {"phone_a": 4.2} if macs else {}}


def _bench(root):
    records = [_record("bicubic", "baseline", "baseline", 28.0, 0.0), _record("m", "mnss", "fp32", 31.0, 900.0),
               _record("m", "mnss", "int8", 30.8, 900.0)]
    section = {"records": {f"{r['name']}/{r['precision']}": r for r in records},
               "settings": {"quick": True, "devices": ["phone_a"], "scale": 2, "data": "tiny_test"}}
    doc = {"format": "mnss-kit-bench", "version": 2, "note": "synthetic", "benches": {"x2": section}}
    atomic_write_json(root / "bench.json", doc)
    from PIL import Image

    (root / "charts" / "x2").mkdir(parents=True)
    Image.new("RGB", (40, 30), (10, 120, 200)).save(root / "charts" / "x2" / "psnr_vs_macs.png")
    return root / "bench.json"


def _stress(root):
    stats = {"psnr": 30.0, "ssim": 0.9, "if_ssim": 0.95, "temporal_error": 0.01, "disocclusion_psnr": 20.0,
             "disocclusion_l1": 0.05, "disoccluded_pixels": 10, "warmup_frames": 1, "frames_to_recover": [2]}
    methods = {"m": stats, "bicubic": dict(stats, psnr=27.0), "taau": dict(stats, psnr=29.0, frames_to_recover=[None])}
    doc = {"format": "mnss-kit-stress", "version": 1, "settings": {"recovery_tolerance_db": 0.5}, "methods": list(methods),
           "not_covered": dict(NOT_COVERED),
           "scenarios": {"camera_cut": {"case": "camera cut <history>", "frames": 3, "cuts": [1], "events": [1],
                                        "jitter_pattern": "mnss", "methods": methods,
                                        "per_frame_psnr": {m: [25.0, 20.0, 29.0] for m in methods}}}}
    write_plots(doc, root / "plots")
    rng = np.random.default_rng(0)
    reference = rng.random((32, 32, 3))
    write_crops(root / "crops", "camera_cut", 2, reference, {m: np.clip(reference + 0.05 * rng.standard_normal((32, 32, 3)), 0, 1)
                                                            for m in methods})
    atomic_write_json(root / "stress.json", doc)
    return root / "stress.json"


def _size(root):
    from mnss_kit.size.charts import write_chart

    def rung(config, macs, psnr, misses):
        return {"config": config, "macs_per_pixel": macs, "params": 100, "psnr": psnr, "ssim": 0.9, "if_ssim": 0.95,
                "device_ms": {"phone_a": macs / 1000}, "steps": 10, "misses": misses}

    doc = {"format": "mnss-kit-size", "version": 1, "targets": ["within:0.3"], "budget": None,
           "settings": {"devices": ["phone_a"], "steps": 10, "train_sequences": ["a", "b"], "test_sequences": ["scene/held"]},
           "rows": {"tiny": rung("tiny", 1700, 30.0, ["PSNR 1.00 dB below big (allowed 0.3)"]), "big": rung("big", 7400, 31.0, [])},
           "baselines": {"taau": {"psnr": 29.5, "ssim": 0.9, "if_ssim": 0.95}}, "choice": {"config": "big"}}
    (root / "size").mkdir()
    atomic_write_json(root / "size" / "size.json", doc)
    write_chart(doc, root / "size" / "size.png")
    return root / "size" / "size.json"


def _open(page, tmp_path):
    """The probe's record and Chromium's console lines for ``page``, loaded with the probe script."""
    probe = page.with_name("probe.html")
    probe.write_text(page.read_text().replace("<head>", "<head>" + PROBE, 1))
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'chromium'}",
           "--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000", "--dump-dom", probe.as_uri()]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    probe.unlink()
    found = re.search(r'<pre id="probe">(.*?)</pre>', done.stdout, re.S)
    assert found, f"the page did not finish loading: {done.stderr[-2000:]}"
    record = json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))
    console = [line for line in done.stderr.splitlines() if ":CONSOLE" in line]
    return record, console


@pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium package (scripts/setup.sh installs it)")
def test_report_loads_in_chromium_with_every_image_and_no_console_error(tmp_path):
    page = build_report(_bench(tmp_path), _stress(tmp_path), tmp_path / "report", sizes=[_size(tmp_path)])
    text = page.read_text()
    assert "(estimate)" in text and "camera cut &lt;history&gt;" in text and "hud_overlay" in text
    assert "Model size for held-out held" in text and "Chosen: <b>big</b>" in text and "1.00 dB below big" in text
    record, console = _open(page, tmp_path)
    sources = [src for src, _ in record["images"]]
    assert "bench/x2/psnr_vs_macs.png" in sources and "stress/plots/camera_cut.png" in sources
    assert any(src.startswith("stress/crops/camera_cut_") for src in sources) and "size/0/size.png" in sources
    assert all(ok for _, ok in record["images"]), record["images"]
    assert record["errors"] == [] and console == [], (record["errors"], console)

    # the same check sees a missing image: it is not a check that always passes
    (tmp_path / "report" / "bench" / "x2" / "psnr_vs_macs.png").unlink()
    record, _ = _open(page, tmp_path)
    assert dict(record["images"])["bench/x2/psnr_vs_macs.png"] is False
    assert record["errors"]


def test_report_command_names_a_wrong_file_and_needs_an_input(tmp_path, capsys):
    assert main(["report", "--out", str(tmp_path / "r")]) == 2
    other = tmp_path / "other.json"
    other.write_text('{"format": "something-else", "version": 1}')
    assert main(["report", "--bench", str(other), "--out", str(tmp_path / "r")]) == 2
    assert "other.json: not a bench file" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()
