import csv
import json
import pytest
import torch

from mnss_kit.cli import main
from mnss_kit.model import checkpoint
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model


TINY = dict(recon_width=4, recon_layers=2, aa_width=4, aa_layers=2)


@pytest.fixture
def checkpoint_file(tmp_path):
    """Write a tiny untrained MNSS checkpoint at a given scale; returns its path."""

    def write(scale=2):
        torch.manual_seed(0)
        model = build_model(MNSSConfig(scale=scale, **TINY))
        return checkpoint.save(tmp_path / f"tiny_x{scale}.pt", model, {"jitter_pattern": "grid"})

    return write


def test_cli_baselines_write_csv_json_and_crops(eval_dataset, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["eval", "none", "--data", str(eval_dataset), "--json", str(out / "s.json"), "--csv", str(out / "f.csv"),
                 "--crops", str(out / "crops"), "--no-progress"])
    assert code == 0
    summary = json.loads((out / "s.json").read_text())
    assert summary["frames"] == 14
    assert set(summary["methods"]) == {"bicubic", "taau"}
    for stats in summary["methods"].values():
        assert {"psnr", "ssim", "if_ssim", "temporal_error"} <= set(stats)
    assert set(summary["sequences"]) == {"pan_cut", "static"}
    assert "per_frame" not in summary
    rows = list(csv.DictReader((out / "f.csv").open()))
    assert len(rows) == 14 * 2 and {"psnr", "if_ssim", "method", "frame"} <= set(rows[0])
    assert list((out / "crops").glob("pan_cut_*_worst.png"))
    table = capsys.readouterr().out
    assert "taau" in table and "IF-SSIM" in table


def test_cli_with_a_model_reports_it(eval_dataset, tmp_path, checkpoint_file):
    path = tmp_path / "s.json"
    ckpt = checkpoint_file(scale=2)
    code = main(["eval", str(ckpt), "--data", str(eval_dataset), "--json", str(path), "--csv", str(tmp_path / "f.csv"),
                 "--crops", str(tmp_path / "crops"), "--max-frames", "3", "--no-progress"])
    assert code == 0
    summary = json.loads(path.read_text())
    assert list(summary["methods"]) == ["model", "model_nohist", "bicubic", "taau"]
    for stats in summary["methods"].values():
        assert {"psnr", "ssim", "if_ssim", "temporal_error"} <= set(stats)
    assert summary["frames"] == 6
    record = checkpoint.load(ckpt)[1]
    assert summary["model"]["name"] == "tiny_x2"
    assert summary["model"]["macs_per_pixel"] == pytest.approx(record["macs_per_pixel"])
    assert summary["model"]["scale"] == 2
    assert list((tmp_path / "crops").glob("*.png"))


def test_cli_scale_mismatch_is_one_line_error(eval_dataset, checkpoint_file, capsys):
    assert main(["eval", str(checkpoint_file(scale=3)), "--data", str(eval_dataset), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert "x2 but the model is x3" in err and "\n" not in err


def test_cli_model_methods_need_a_model(eval_dataset, capsys):
    assert main(["eval", "none", "--data", str(eval_dataset), "--methods", "model", "--no-progress"]) == 2
    assert "need a model" in capsys.readouterr().err


def test_cli_missing_data_dir(tmp_path, capsys):
    assert main(["eval", "none", "--data", str(tmp_path / "nope"), "--no-progress"]) == 2
    assert "not found" in capsys.readouterr().err
