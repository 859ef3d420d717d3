"""The bench's logic without its measurements: the Pareto front, the record schema, resuming a
killed run, and the charts drawn from a bench document."""

from __future__ import annotations

import json

import pytest

from mnss_kit.bench import run as bench_run
from mnss_kit.bench.charts import write_charts
from mnss_kit.bench.pareto import pareto_front
from mnss_kit.bench.records import record_problems
from mnss_kit.model import checkpoint


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


class Calls(list):
    """The measurements made, in order; ``digests`` stands for the checkpoint files."""

    digests: dict


@pytest.fixture
def fake_measurements(monkeypatch, tmp_path):
    """The bench with data preparation and measurements replaced by counters and fixed records."""
    calls = Calls()
    monkeypatch.setattr(bench_run, "_rendered", lambda config, overrides, root, progress: tmp_path / config)
    monkeypatch.setattr(bench_run, "_calibration_data", lambda root, scale, progress: tmp_path / "calibration")
    monkeypatch.setattr(bench_run, "model_scale", lambda name: 4 if name.endswith("_x4") else 2)
    monkeypatch.setattr(bench_run, "baseline_records", lambda data, settings: calls.append("baselines") or [
        good_record(name=b, family="baseline", precision="baseline", macs_per_pixel=0.0, cpu_ms=None, device_ms={})
        for b in bench_run.BASELINES])

    digests = {}  # checkpoint name -> its file's digest; a test retrains a model by changing it
    monkeypatch.setattr("mnss_kit.model.checkpoint.digest", lambda name: digests.get(name, f"first {name}"))

    def model_records(name, data, calibration, settings, work):
        calls.append(name)
        if name == "crash":
            raise KeyboardInterrupt  # a run killed in the middle of a model
        return [good_record(name=name, precision=p, checkpoint_sha256=checkpoint.digest(name)) for p in ("fp32", "int8")]

    monkeypatch.setattr(bench_run, "model_records", model_records)
    calls.digests = digests
    return calls


def _keys(doc, section="x2"):
    return set(doc["benches"][section]["records"])


def test_a_killed_run_resumes_with_the_records_it_has(fake_measurements, tmp_path):
    out = tmp_path / "bench.json"
    request = dict(out=out, work=tmp_path / "work", devices=["snapdragon_8_gen_1"], quick=True, progress=False)
    with pytest.raises(KeyboardInterrupt):
        bench_run.run_bench(bench_run.BenchRequest(models=["a", "crash"], **request))
    assert _keys(json.loads(out.read_text())) == {"bicubic/baseline", "taau/baseline", "a/fp32", "a/int8"}
    fake_measurements.clear()
    doc = bench_run.run_bench(bench_run.BenchRequest(models=["a", "b"], **request))
    assert fake_measurements == ["b"]  # the baselines and model a were kept
    assert _keys(doc) == {"bicubic/baseline", "taau/baseline", "a/fp32", "a/int8", "b/fp32", "b/int8"}
    fake_measurements.digests["b"] = "retrained b"
    fake_measurements.clear()
    doc = bench_run.run_bench(bench_run.BenchRequest(models=["a", "b"], **request))
    assert fake_measurements == ["b"]  # the same name, another checkpoint file: benched again
    assert doc["benches"]["x2"]["records"]["b/int8"]["checkpoint_sha256"] == "retrained b"
    fake_measurements.clear()
    bench_run.run_bench(bench_run.BenchRequest(models=["a"], **{**request, "quick": False}))
    assert fake_measurements == ["baselines", "a"]  # other settings: nothing reused


def test_every_scale_gets_its_own_section_in_one_file(fake_measurements, tmp_path, monkeypatch):
    from mnss_kit.errors import UserError

    request = dict(out=tmp_path / "bench.json", work=tmp_path / "work", devices=["snapdragon_8_gen_1"], quick=True, progress=False)
    doc = bench_run.run_bench(bench_run.BenchRequest(models=["a", "model_x4", "b"], **request))
    assert [name for name, _ in bench_run.sections(doc)] == ["x2", "x4"]
    assert _keys(doc, "x4") == {"bicubic/baseline", "taau/baseline", "model_x4/fp32", "model_x4/int8"}
    assert _keys(doc, "x2") == {"bicubic/baseline", "taau/baseline", "a/fp32", "a/int8", "b/fp32", "b/int8"}
    assert doc["benches"]["x4"]["settings"]["data"] == "tiny_test scale=4 jitter=halton"
    assert doc["benches"]["x2"]["settings"]["data"] == "tiny_test"
    with pytest.raises(UserError, match=r"model_x4 is x4 but the bench is x2 \(leave out --scale and --data"):
        bench_run.run_bench(bench_run.BenchRequest(models=["a", "model_x4"], scale=2, **request))
    fake_measurements.clear()
    monkeypatch.chdir(tmp_path)  # default_models also reads ./runs
    monkeypatch.setattr("mnss_kit.model.checkpoint.shipped_names", lambda: ["a", "model_x4"])
    doc = bench_run.run_bench(bench_run.BenchRequest(scale=4, **request))  # the default models of x4 only
    assert fake_measurements == [] and "x2" in doc["benches"]  # x4 resumed, the x2 section kept
    assert bench_run.models_by_scale(bench_run.BenchRequest(**request)) == {2: ["a"], 4: ["model_x4"]}


def test_the_command_writes_where_out_says_and_else_under_runs(fake_measurements, tmp_path, monkeypatch, capsys):
    """``mnss-kit bench --out D`` writes D/bench.json and D/charts/; without --out the results go
    to runs/bench/ of the working directory, never into its bench/ (the micro-benchmarks' name)."""
    from mnss_kit.cli import main

    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    args = ["bench", "--models", "a", "--quick", "--devices", "snapdragon_8_gen_1", "--no-progress"]
    out = tmp_path / "D"
    assert main([*args, "--out", str(out)]) == 0
    doc = json.loads((out / "bench.json").read_text())
    assert _keys(doc) == {"bicubic/baseline", "taau/baseline", "a/fp32", "a/int8"}
    assert (out / "charts" / "x2" / "psnr_vs_macs.png").is_file()
    assert list(cwd.iterdir()) == []  # nothing in the working directory: no bench/, no runs/
    assert f"wrote {out / 'bench.json'}" in capsys.readouterr().out

    assert main(args) == 0
    assert json.loads((cwd / "runs" / "bench" / "bench.json").read_text()) == doc  # the same JSON
    assert (cwd / "runs" / "bench" / "charts" / "x2").is_dir()
    assert not (cwd / "bench").exists()
    assert main([*args, "--out", str(tmp_path / "named.json")]) == 0  # a .json path is the file itself
    assert json.loads((tmp_path / "named.json").read_text()) == doc and (tmp_path / "charts" / "x2").is_dir()


def test_charts_are_drawn_per_scale_from_a_bench_document(tmp_path):
    records = {f"{n}/{p}": good_record(name=n, precision=p, psnr=30 + i + (0.1 if p == "fp32" else 0.0), macs_per_pixel=1000.0 * (i + 1))
               for i, n in enumerate(("small", "large")) for p in ("fp32", "int8")}
    records["taau/baseline"] = good_record(name="taau", family="baseline", precision="baseline", cpu_ms=None, device_ms={})
    settings = {"quick": True, "devices": ["snapdragon_8_gen_1"], "data": "tiny_test"}
    doc = {"benches": {"x4": {"settings": {**settings, "scale": 4}, "records": records},
                       "x2": {"settings": {**settings, "scale": 2}, "records": records}}}
    written = write_charts(doc, tmp_path / "charts")
    stems = {"psnr_vs_macs.png", "psnr_vs_cpu_ms.png", "if_ssim_vs_macs.png", "psnr_vs_ms_snapdragon_8_gen_1.png", "int8_loss.png"}
    assert {f"{p.parent.name}/{p.name}" for p in written} == {f"{s}/{n}" for s in ("x2", "x4") for n in stems}
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in written)


def test_the_full_bench_renders_only_the_frames_it_measures():
    from mnss_kit.render.config import load_render_config

    for scale in (2, 4):
        config, overrides = bench_run.held_out_config(False, scale)
        sequences = load_render_config(config, overrides).sequences
        assert {s.frames for s in sequences} == {bench_run.FULL["max_frames"]}, (config, overrides)
