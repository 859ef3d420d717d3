"""The demo: a tiny model of the default family through every stage, and a report whose tables name
their data and include the emulator's result."""

import argparse
import json

from mnss_kit import demo
from mnss_kit.model import checkpoint
from mnss_kit.train.config import load_experiment


def metrics(psnr):
    return {"psnr": psnr, "ssim": psnr / 100, "if_ssim": psnr / 200}


def write_eval(path, methods, macs):
    sequences = {"arena_tiny_test": {}, "town_tiny_test": {}}
    path.write_text(json.dumps({"methods": {k: metrics(v) for k, v in methods.items()}, "model": {"macs_per_pixel": macs},
                                "sequences": sequences, "frames": 24}))


def write_int8_and_emulation(root):
    """The quantize report (held-out comparison), the golden check and the emulator's metrics."""
    (root / "int8").mkdir()
    per_sequence = [{"sequence": s, "frames": 12, "fp32": metrics(p), "int8": metrics(p - 0.01)}
                    for s, p in (("arena_tiny_test", 40.9), ("town_tiny_test", 32.18))]
    (root / "int8" / "report.json").write_text(json.dumps({
        "fp32": metrics(36.54), "int8": metrics(36.53), "sequences": per_sequence, "samples": 24, "data": "data/train",
        "evaluation": {"data": "data/test", "held_out": True, "sequences": 2, "frames": 24, "int8_runtime": "tflite-ref"}}))
    (root / demo.GOLDEN_CHECK).write_text(json.dumps({"frames": 3, "profile": "tflite-ref", "mismatch": None,
                                                      "source": "dataset data/test, sequence arena_tiny_test, frames 0..2",
                                                      "compared": ["display", "npu_input", "npu_output"]}))
    (root / "emulate").mkdir()
    (root / "emulate" / "metrics.json").write_text(json.dumps({"sequences": {
        "arena_tiny_test": {"summary": {"frames": 12, "mean_psnr_db": 40.71}},
        "town_tiny_test": {"summary": {"frames": 12, "mean_psnr_db": 32.05}}}}))


def table_rows(report):
    return {cells[0]: cells[1:] for line in report.read_text().splitlines() if line.startswith("| ")
            for cells in [[c.strip() for c in line.strip("|").split("|")]]}


def test_demo_trains_a_tiny_model_of_the_default_family():
    tiny, default = load_experiment(demo.MODEL_CONFIG)[0], load_experiment(demo.SHIPPED_MODEL)[0]
    assert tiny.model.family == default.model.family == "ntaau_lr"
    assert tiny.model.width < load_experiment("ntaau_lr_x2_small")[0].model.width


def test_report_shows_the_shipped_model_beside_the_tiny_one_and_the_baselines(tmp_path):
    write_eval(tmp_path / "eval.json", {"model": 31.25, "bicubic": 29.5, "taau": 30.75}, 1058.0)
    write_eval(tmp_path / "eval_shipped.json", {"model": 32.5}, 2871.5)
    rows = table_rows(demo.write_report(tmp_path, {"train": 1.0}))
    assert rows[f"model ({demo.MODEL_CONFIG}, trained here)"][::3] == ["31.25", "1058.0"]
    assert rows[f"model ({demo.SHIPPED_MODEL}, shipped)"][::3] == ["32.50", "2871.5"]
    assert rows["bicubic"][::3] == ["29.50", "-"] and rows["taau"][::3] == ["30.75", "-"]
    assert (tmp_path / "quality_vs_cost.png").stat().st_size > 0


def test_each_table_names_its_data_and_the_emulator_result_is_reported(tmp_path):
    write_eval(tmp_path / "eval.json", {"model": 36.54, "bicubic": 34.9, "taau": 36.4}, 1058.0)
    write_int8_and_emulation(tmp_path)
    report = demo.write_report(tmp_path, {})
    text = report.read_text()
    assert ("Data: held-out set tiny_test (arena_tiny_test, town_tiny_test; 24 frames, never trained on); every method "
            "on the same frames.") in text
    assert "Calibration: 24 recorded stage inputs from the training set (data/train)." in text
    assert "Comparison data: data/test (held-out, never trained on; 2 sequences, 24 frames)" in text
    assert ("Golden frames (dataset data/test, sequence arena_tiny_test, frames 0..2; display, npu_input, npu_output "
            "compared, numerics tflite-ref): the emulator reproduced all 3 within the manifest's tolerances.") in text
    rows = table_rows(report)
    assert rows["fp32"][0] == "36.54" and rows["int8"][0] == "36.53"
    assert rows["arena_tiny_test"] == ["12", "40.90", "40.89", "40.71"]
    assert rows["town_tiny_test"] == ["12", "32.18", "32.17", "32.05"]


def test_report_says_which_steps_did_not_run(tmp_path):
    write_eval(tmp_path / "eval.json", {"model": 31.0, "taau": 30.0}, 1058.0)
    report = demo.write_report(tmp_path, {})
    rows, text = table_rows(report), report.read_text()
    assert not any(demo.SHIPPED_MODEL + ", shipped" in name for name in rows)
    assert f"`{demo.SHIPPED_MODEL}` not evaluated" in text
    assert "Not run: no fp32-vs-int8 comparison" in text and "Not run: no bundle" in text


class RecordingSteps:
    def __init__(self, mismatch=None):
        self.calls, self.timings, self.mismatch = [], {}, mismatch

    def run(self, title, done, argv, optional=False):
        self.calls.append(argv)
        if argv[0] == "export":
            done.parent.mkdir(parents=True)
            done.write_text("{}")

    def call(self, title, done, work):
        self.calls.append([title])
        done.write_text(json.dumps({"mismatch": self.mismatch}))


def test_the_chain_measures_int8_and_the_emulator_on_the_held_out_set(tmp_path, monkeypatch):
    recorded = RecordingSteps()
    monkeypatch.setattr(demo, "Steps", lambda out, progress: recorded)
    monkeypatch.setattr(demo, "write_report", lambda out, timings: out / "report.md")
    demo.run(argparse.Namespace(out=str(tmp_path), minutes=2.0, no_progress=True))
    argv = {call[0]: call for call in recorded.calls}
    test_data, train_data = str(tmp_path / "data" / "test"), str(tmp_path / "data" / "train")
    assert argv["train"][1] == "ntaau_lr_x2_tiny"
    assert argv["quantize"][argv["quantize"].index("--data") + 1] == train_data  # calibration
    assert argv["quantize"][argv["quantize"].index("--eval-data") + 1] == test_data  # the fp32-vs-int8 table
    assert argv["export"][argv["export"].index("--data") + 1] == test_data  # golden frames from held-out frames
    assert "emulator on golden frames" in argv
    assert argv["emulate"][argv["emulate"].index("--data") + 1] == test_data and "--frames" not in argv["emulate"]


def test_a_bundle_the_emulator_does_not_reproduce_is_not_emulated(tmp_path, monkeypatch):
    recorded = RecordingSteps(mismatch="frame 0: display")
    monkeypatch.setattr(demo, "Steps", lambda out, progress: recorded)
    monkeypatch.setattr(demo, "write_report", lambda out, timings: out / "report.md")
    demo.run(argparse.Namespace(out=str(tmp_path), minutes=2.0, no_progress=True))
    assert "emulator on golden frames" in [c[0] for c in recorded.calls]
    assert "emulate" not in [c[0] for c in recorded.calls]


def test_shipped_model_is_evaluated_on_the_held_out_set_when_shipped(tmp_path, monkeypatch):
    steps = RecordingSteps()
    demo.evaluate_shipped(steps, tmp_path / "test", tmp_path / "eval_shipped.json")
    assert steps.calls == [["eval", demo.SHIPPED_MODEL, "--data", str(tmp_path / "test"),
                            "--json", str(tmp_path / "eval_shipped.json"), "--methods", "model"]]
    monkeypatch.setattr(checkpoint, "ZOO_DIR", tmp_path)  # an installation that ships no checkpoint
    steps = RecordingSteps()
    demo.evaluate_shipped(steps, tmp_path / "test", tmp_path / "eval_shipped.json")
    assert steps.calls == []


def test_report_names_the_golden_frame_the_emulator_does_not_reproduce(tmp_path):
    write_eval(tmp_path / "eval.json", {"model": 36.54, "taau": 36.4}, 1058.0)
    write_int8_and_emulation(tmp_path)
    check = json.loads((tmp_path / demo.GOLDEN_CHECK).read_text())
    (tmp_path / demo.GOLDEN_CHECK).write_text(json.dumps(dict(check, mismatch="frame 1: display")))
    (tmp_path / "emulate" / "metrics.json").unlink()
    text = demo.write_report(tmp_path, {}).read_text()
    assert "the emulator did not reproduce them: frame 1: display." in text
