"""The generated block of docs/training.md's worked example, from a fabricated report of
scripts/finetune_example.py (logic only: no render, training or eval)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"
DOC = """# Training

before

<!-- BEGIN GENERATED: finetune-example -->
stale numbers
<!-- END GENERATED: finetune-example -->

after
"""


@pytest.fixture(scope="module")
def script():
    sys.path.insert(0, str(SCRIPTS))
    try:
        spec = importlib.util.spec_from_file_location("finetune_example", SCRIPTS / "finetune_example.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(SCRIPTS))


def report(tuned_psnr: float) -> dict:
    methods = {"fine-tuned": {"psnr": tuned_psnr, "ssim": 0.91, "if_ssim": 0.985},
               "mnss_x2 (shipped)": {"psnr": 30.0, "ssim": 0.90, "if_ssim": 0.98},
               "TAAU": {"psnr": 29.5, "ssim": 0.89, "if_ssim": None},
               "bicubic": {"psnr": 28.0, "ssim": 0.85, "if_ssim": 0.95}}
    return {
        "model": "mnss_x2", "fine_tune_sequences": ["0000", "0001"], "held_out_sequences": {"0002": 48, "0003": 48},
        "rendered_as": {"0000": "factory_s11", "0001": "factory_s12", "0002": "factory_s13", "0003": "factory_s14"},
        "training": {"minutes": 10.0, "settings": ["train.lr=1.0e-4"], "steps": 1234, "wall_time_s": 600.0,
                     "steps_per_second": 2.06, "final_loss": 0.05, "stopped": "time_budget"},
        "methods": methods,
        "sequences": {"0002": {k: dict(v, psnr=v["psnr"] - 1) for k, v in methods.items()},
                      "0003": {k: dict(v, psnr=v["psnr"] + 1) for k, v in methods.items()}},
        "steps": {"train": {"command": "mnss-kit train mnss_x2 --init mnss_x2 --out run", "seconds": 630.0}},
    }


def test_block_holds_the_reports_numbers_and_nothing_else_changes(script, tmp_path):
    doc = tmp_path / "training.md"
    doc.write_text(DOC)
    script.write_doc(report(30.5), doc)
    text = doc.read_text()
    assert "stale numbers" not in text and text.startswith("# Training\n\nbefore\n") and text.endswith("after\n")
    assert "| fine-tuned | 30.50 | 0.9100 | 0.9850 | 29.50 | 31.50 |" in text
    assert "| TAAU | 29.50 | 0.8900 | n/a | 28.50 | 30.50 |" in text
    assert "0002 (factory_s13, 48 frames)" in text and "1234 steps at 2.06 steps/s" in text
    assert "gained +0.50 dB PSNR over the shipped weights" in text and "IF-SSIM +0.0050" in text
    assert "    mnss-kit train mnss_x2 --init mnss_x2 --out run    # 10.5 min" in text and "10.5 min in all" in text
    assert "python scripts/finetune_example.py --doc-only" in text  # says how to regenerate it
    script.write_doc(report(30.5), doc)
    assert doc.read_text() == text  # regenerating from the same report changes nothing


def test_a_fine_tune_that_loses_says_so(script):
    block = script.doc_block(report(29.8))
    assert "did not beat the shipped weights on the held-out sequences (-0.20 dB PSNR)" in block
    assert "gained" not in block


def test_a_doc_without_the_block_is_refused(script, tmp_path):
    doc = tmp_path / "training.md"
    doc.write_text("# Training\n")
    with pytest.raises(SystemExit, match="no generated block 'finetune-example'"):
        script.write_doc(report(30.5), doc)
    assert doc.read_text() == "# Training\n"
