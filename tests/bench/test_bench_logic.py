"""The bench's logic without its measurements: the Pareto front, the record schema, resuming a
killed run, and the charts drawn from a bench document."""

from __future__ import annotations

import json

import pytest

from mnss_kit.bench import run as bench_run
from mnss_kit.bench.charts import write_charts
from mnss_kit.bench.pareto import pareto_front
from mnss_kit.bench.records import record_problems


def test_pareto_front_keeps_exactly_the_undominated_points():
    points = [(100, 30.0), (200, 32.0), (150, 29.0), (300, 31.0), (200, 32.0), (50, 25.0)]
    assert pareto_front(points) == [5, 0, 1, 4]  # (150, 29) and (300, 31) are dominated; equal points both stay
    assert pareto_front([]) == []
    assert pareto_front([(1.0, 1.0)]) == [0]


def good_record(**changes) -> dict:
    record = {"name": "m", "family": "mnss", "precision": "int8", "psnr": 35.0, "ssim": 0.96, "if_ssim": 0.99,
              "macs_per_pixel": 7414.0, "cpu_ms": {"xnnpack": 12.0}, "device_ms": {"snapdragon_8_gen_1": 1.0}}
    return {**record, **changes}


@pytest.mark.parametrize("changes, problem", [
    ({}, None),
    ({"precision": "int4"}, "precision"),
    ({"psnr": float("nan")}, "psnr"),
    ({"macs_per_pixel": "7k"}, "macs_per_pixel"),
    ({"device_ms": None}, "device_ms"),
    ({"cpu_ms": 3.0}, "cpu_ms"),
])
def test_record_schema(changes, problem):
    problems = record_problems(good_record(**changes))
    assert (problems == []) if problem is None else any(problem in p for p in problems)
    broken = good_record()
    del broken["if_ssim"]
    assert record_problems(broken) == ["missing key 'if_ssim'"]


@pytest.fixture
def fake_measurements(monkeypatch, tmp_path):
    """The bench with data preparation and measurements replaced by counters and fixed records."""
    calls = []
    monkeypatch.setattr(bench_run, "_rendered", lambda config, overrides, scale, root, progress: tmp_path / config)
    monkeypatch.setattr(bench_run, "_calibration_data", lambda root, scale, progress: tmp_path / "calibration")
    monkeypatch.setattr(bench_run, "model_scale", lambda name: 4 if name.endswith("_x4") else 2)
    monkeypatch.setattr(bench_run, "baseline_records", lambda data, settings: calls.append("baselines") or [
        good_record(name=b, family="baseline", precision="baseline", macs_per_pixel=0.0, cpu_ms=None, device_ms={})
        for b in bench_run.BASELINES])

    def model_records(name, data, calibration, settings, work):
        calls.append(name)
        if name == "crash":
            raise KeyboardInterrupt  # a run killed in the middle of a model
        return [good_record(name=name, precision=p) for p in ("fp32", "int8")]

    monkeypatch.setattr(bench_run, "model_records", model_records)
    return calls


def test_a_killed_run_resumes_with_the_records_it_has(fake_measurements, tmp_path):
    out = tmp_path / "bench.json"
    request = dict(out=out, work=tmp_path / "work", devices=["snapdragon_8_gen_1"], quick=True, progress=False)
    with pytest.raises(KeyboardInterrupt):
        bench_run.run_bench(bench_run.BenchRequest(models=["a", "crash"], **request))
    assert set(json.loads(out.read_text())["records"]) == {"bicubic/baseline", "taau/baseline", "a/fp32", "a/int8"}
    fake_measurements.clear()
    doc = bench_run.run_bench(bench_run.BenchRequest(models=["a", "b"], **request))
    assert fake_measurements == ["b"]  # the baselines and model a were kept
    assert set(doc["records"]) == {"bicubic/baseline", "taau/baseline", "a/fp32", "a/int8", "b/fp32", "b/int8"}
    fake_measurements.clear()
    bench_run.run_bench(bench_run.BenchRequest(models=["a"], **{**request, "quick": False}))
    assert fake_measurements == ["baselines", "a"]  # other settings: nothing reused


def test_one_bench_is_one_scale(fake_measurements, tmp_path, monkeypatch):
    from mnss_kit.errors import UserError

    request = dict(out=tmp_path / "bench.json", work=tmp_path / "work", devices=["snapdragon_8_gen_1"], quick=True, progress=False)
    with pytest.raises(UserError, match=r"model_x4 is x4 but the bench is x2 \(bench one scale at a time: --scale\)"):
        bench_run.run_bench(bench_run.BenchRequest(models=["a", "model_x4"], **request))
    doc = bench_run.run_bench(bench_run.BenchRequest(models=["model_x4"], scale=4, **request))
    assert doc["settings"]["scale"] == 4 and doc["settings"]["data"] == "tiny_test scale=4 jitter=halton"
    monkeypatch.setattr("mnss_kit.model.checkpoint.shipped_names", lambda: ["a", "model_x4"])
    assert bench_run.default_models(4, runs=tmp_path / "no_runs") == ["model_x4"]
    assert bench_run.default_models(2, runs=tmp_path / "no_runs") == ["a"]


def test_charts_are_drawn_from_a_bench_document(tmp_path):
    records = {f"{n}/{p}": good_record(name=n, precision=p, psnr=30 + i + (0.1 if p == "fp32" else 0.0), macs_per_pixel=1000.0 * (i + 1))
               for i, n in enumerate(("small", "large")) for p in ("fp32", "int8")}
    records["taau/baseline"] = good_record(name="taau", family="baseline", precision="baseline", cpu_ms=None, device_ms={})
    doc = {"settings": {"quick": True, "devices": ["snapdragon_8_gen_1"]}, "records": records}
    written = write_charts(doc, tmp_path / "charts")
    assert {p.name for p in written} == {"psnr_vs_macs.png", "psnr_vs_cpu_ms.png", "if_ssim_vs_macs.png",
                                         "psnr_vs_ms_snapdragon_8_gen_1.png", "int8_loss.png"}
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in written)
