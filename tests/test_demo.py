"""The demo's report: the model it trains beside the shipped default model and the baselines."""

import json

from mnss_kit import demo
from mnss_kit.model import checkpoint


def metrics(psnr):
    return {"psnr": psnr, "ssim": psnr / 100, "if_ssim": psnr / 200}


def write_eval(path, methods, macs):
    path.write_text(json.dumps({"methods": {k: metrics(v) for k, v in methods.items()}, "model": {"macs_per_pixel": macs}}))


def table_rows(report):
    return {cells[0]: cells[1:] for line in report.read_text().splitlines() if line.startswith("| ")
            for cells in [[c.strip() for c in line.strip("|").split("|")]]}


def test_report_shows_the_shipped_model_beside_the_tiny_one_and_the_baselines(tmp_path):
    write_eval(tmp_path / "eval.json", {"model": 31.25, "bicubic": 29.5, "taau": 30.75}, 1726.0)
    write_eval(tmp_path / "eval_shipped.json", {"model": 32.5}, 7414.0)
    rows = table_rows(demo.write_report(tmp_path, {"train": 1.0}))
    assert rows[f"model ({demo.MODEL_CONFIG}, trained here)"][::3] == ["31.25", "1726.0"]
    assert rows[f"model ({demo.SHIPPED_MODEL}, shipped)"][::3] == ["32.50", "7414.0"]
    assert rows["bicubic"][::3] == ["29.50", "-"] and rows["taau"][::3] == ["30.75", "-"]
    assert (tmp_path / "quality_vs_cost.png").stat().st_size > 0


def test_report_without_a_shipped_evaluation_lists_the_demo_model_only(tmp_path):
    write_eval(tmp_path / "eval.json", {"model": 31.0, "taau": 30.0}, 1726.0)
    rows = table_rows(demo.write_report(tmp_path, {}))
    assert not any(demo.SHIPPED_MODEL + ", shipped" in name for name in rows)


class RecordingSteps:
    def __init__(self):
        self.calls = []

    def run(self, title, done, argv, optional=False):
        self.calls.append(argv)


def test_shipped_model_is_evaluated_on_the_held_out_set_when_shipped(tmp_path, monkeypatch):
    steps = RecordingSteps()
    demo.evaluate_shipped(steps, tmp_path / "test", tmp_path / "eval_shipped.json")
    assert steps.calls == [["eval", demo.SHIPPED_MODEL, "--data", str(tmp_path / "test"),
                            "--json", str(tmp_path / "eval_shipped.json"), "--methods", "model"]]
    monkeypatch.setattr(checkpoint, "ZOO_DIR", tmp_path)  # an installation that ships no checkpoint
    steps = RecordingSteps()
    demo.evaluate_shipped(steps, tmp_path / "test", tmp_path / "eval_shipped.json")
    assert steps.calls == []
