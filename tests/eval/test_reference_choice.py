"""eval --reference: the metrics compare against the box, the native TAA or the 4-sample reference."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from mnss_kit.cli import main
from mnss_kit.dataset import format as fmt
from mnss_kit.errors import UserError
from mnss_kit.eval.baselines import baseline_methods
from mnss_kit.eval.command import REFERENCES
from mnss_kit.eval.loop import evaluate


@pytest.fixture
def with_taa(static_sequence, tmp_path):
    """The static sequence plus a reference_taa that is its box reference darkened by half."""
    seq = shutil.copytree(static_sequence, tmp_path / "static")
    meta = fmt.read_meta(seq)
    for t in range(meta.frame_count):
        fmt.write_buffer(seq, "hr", "reference_taa", t, 0.5 * fmt.read_raw_buffer(seq, "hr", "reference", t))
    fmt.write_meta(seq, fmt.replace_meta(meta, buffers={**meta.buffers, "hr": [*meta.buffers["hr"], "reference_taa"]}))
    return seq


def psnr_rows(result) -> list[float]:
    return [r["psnr"] for r in result["per_frame"]]


def test_taa_reference_replaces_the_target_and_never_reaches_the_methods(with_taa):
    seen = []

    def bicubic_watching_inputs(frame, state):
        seen.append(set(frame))
        return bicubic(frame, state)

    bicubic = baseline_methods(2, names=("bicubic",))["bicubic"]
    box = evaluate({"bicubic": bicubic}, with_taa, max_frames=3, progress=False)
    taa = evaluate({"bicubic": bicubic_watching_inputs}, with_taa, max_frames=3, progress=False, reference="taa")
    assert box["settings"]["reference"] == "box" and taa["settings"]["reference"] == "taa"
    assert all(t < b - 6 for t, b in zip(psnr_rows(taa), psnr_rows(box)))  # the darkened target is far off
    assert seen and not any(k.startswith("hr_reference") or k == "reference" for keys in seen for k in keys)


def test_missing_reference_buffer_is_one_line(with_taa):
    with pytest.raises(UserError, match=r"no hr/reference_4x for --reference 4x \(render the data with extra_references: \[4x\]"):
        evaluate(baseline_methods(2), with_taa, progress=False, reference="4x")


def test_cli_reference_option(with_taa, capsys):
    assert main(["eval", "none", "--data", str(with_taa), "--methods", "bicubic", "--max-frames", "2",
                 "--reference", "taa", "--no-progress"]) == 0
    assert "against the taa reference" in capsys.readouterr().out
    assert main(["eval", "none", "--data", str(with_taa), "--reference", "4x", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert "no hr/reference_4x" in err and "\n" not in err


def test_cli_choices_are_the_format_references():
    assert REFERENCES == tuple(fmt.REFERENCE_BUFFERS)
