"""``mnss-kit export`` does what it is asked or says why not: data of another scale is refused,
golden frames beyond the data are refused, frames it renders in place of given data are announced
on stderr, and the calibration frames it renders itself are at the model's scale."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
import torch

from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.errors import UserError
from mnss_kit.model import checkpoint
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model, randomise_convs

from fault_helpers import assert_one_line_fault, run_cli


@pytest.fixture(scope="module")
def made(tmp_path_factory, synthetic_dataset) -> dict[str, Path]:
    """A tiny x2 checkpoint, its quantize directory, and datasets at x4 and at another x2 size."""
    from mnss_kit.cli import main

    root = tmp_path_factory.mktemp("export_faults")
    torch.manual_seed(0)
    model = randomise_convs(build_model(load_model_config("mnss_x2_tiny")).eval())
    ckpt = checkpoint.save(root / "tiny.pt", model, {"jitter_pattern": "grid"})
    qdir = root / "int8"
    assert main(["quantize", str(ckpt), "--data", str(synthetic_dataset), "--out", str(qdir), "--frames", "2",
                 "--pipeline-frames", "0", "--no-progress"]) == 0
    x4 = root / "data_x4"
    write_synthetic_sequence(x4 / "pan_x4", lr_size=(16, 12), scale=4, frames=4, pattern="halton", name="pan_x4")
    small = root / "data_small"
    write_synthetic_sequence(small / "small", lr_size=(16, 12), scale=2, frames=4, name="small")
    return {"ckpt": ckpt, "qdir": qdir, "x2": synthetic_dataset, "x4": x4, "small": small}


def _export(model, scratch: Path, *extra) -> list:
    return ["export", model, "--out", scratch / "out", "--no-progress", *extra]


CASES = {
    # (argv from the artefacts, words of the one line)
    "x4-data-for-x2-checkpoint": (lambda m, s: _export(m["ckpt"], s, "--resolution", "64x48", "--data", m["x4"]),
                                  ["pan_x4", "x4", "tiny is x2"]),
    "x4-data-for-x2-quantize-dir": (lambda m, s: _export(m["qdir"], s, "--checkpoint", m["ckpt"], "--data", m["x4"]),
                                    ["pan_x4", "x4", "tiny is x2"]),
    "more-golden-frames-than-data": (lambda m, s: _export(m["qdir"], s, "--checkpoint", m["ckpt"], "--data", m["x2"],
                                                          "--golden-frames", 50),
                                     ["--golden-frames 50", "8 frames", "at most 8"]),
    "data-not-a-directory": (lambda m, s: _export(m["qdir"], s, "--checkpoint", m["ckpt"], "--data", s / "nowhere"),
                             ["--data", "nowhere", "not a directory"]),
}


@pytest.mark.parametrize("case", CASES.values(), ids=CASES.keys())
def test_export_refuses_what_it_cannot_do_as_asked(case, made, tmp_path, capsys):
    argv, words = case
    assert_one_line_fault(argv(made, tmp_path), words, 2, tmp_path, capsys)


def test_rendering_in_place_of_given_data_is_said_on_stderr(made, tmp_path, capsys, caplog):
    caplog.set_level(logging.INFO)
    code, lines, _ = run_cli(_export(made["qdir"], tmp_path, "--checkpoint", made["ckpt"], "--data", made["small"],
                                     "--golden-frames", 2), capsys)
    assert code == 0, lines
    warnings = [line for line in lines if line.startswith("WARNING ")]
    assert len(warnings) == 1 and str(made["small"]) in warnings[0] and "rendered" in warnings[0], lines


def test_calibration_frames_rendered_for_an_x4_model_are_x4(tmp_path, capsys, monkeypatch):
    """fusesr_x4_l without --data: the frames export renders to calibrate are at x4 (they were x2,
    and the export then failed on its own frames)."""
    from mnss_kit.quantize import run as quantize_run

    asked = {}

    def render(root, progress, with_reference=True, overrides=None, scale=2, jitter=None):
        asked.update(scale=scale, jitter=jitter)
        raise UserError("stop before rendering")  # the render itself needs EGL and a minute

    monkeypatch.setattr(quantize_run, "render_calibration_data", render)
    code, lines, _ = run_cli(_export("fusesr_x4_l", tmp_path, "--resolution", "640x360"), capsys)
    assert code == 2 and lines == ["mnss-kit export: error: stop before rendering"], lines
    record = checkpoint.load("fusesr_x4_l")[1]
    assert asked == {"scale": 4, "jitter": checkpoint.bundle_pattern(record)}
