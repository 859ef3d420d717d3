"""Arguments the fault corpus (scripts/fault_corpus.py) found refused late or under another flag's name:
``demo --minutes nan`` rendered and cached for 20 s before its train step failed, and ``size
--output-size big`` was refused as ``--resolution``."""

from __future__ import annotations

import pytest

from fault_helpers import assert_one_line_fault


@pytest.mark.parametrize("minutes", ["nan", "inf", "-1", "0"])
def test_demo_minutes_not_a_positive_number_is_refused_first(minutes, tmp_path, capsys):
    line = assert_one_line_fault(["demo", "--out", tmp_path / "out", "--minutes", minutes, "--no-progress"],
                                 ["--minutes", "positive"], 2, tmp_path, capsys)
    assert "train" not in line


@pytest.mark.parametrize("size", ["big", "0x0", "100000x100000"])
def test_size_output_size_errors_name_output_size(size, synthetic_dataset, tmp_path, capsys):
    line = assert_one_line_fault(["size", "--data", synthetic_dataset, "--target", "psnr:10", "--output-size", size,
                                  "--out", tmp_path / "out", "--no-progress"], ["--output-size", size], 2, tmp_path,
                                 capsys)
    assert "--resolution" not in line
