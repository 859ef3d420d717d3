"""PSNR has one definition and one convention: ``inf`` for identical images, ``null`` in JSON."""

import json
import math

import numpy as np
import pytest

from mnss_kit.emulate.compare import TensorStats, accumulate
from mnss_kit.emulate.dump import entry_for
from mnss_kit.emulate.run import summarize
from mnss_kit.eval.summary import method_stats
from mnss_kit.fileio import json_safe, json_text
from mnss_kit.metrics.psnr import mse_psnr, psnr


def test_psnr_is_peak_over_mse():
    a = np.zeros((4, 5, 3))
    assert psnr(a + 0.1, a) == pytest.approx(20.0)
    assert psnr(a + 25.5, a, data_range=255.0) == pytest.approx(20.0)
    assert mse_psnr(0.0) == math.inf and psnr(a, a) == math.inf
    with pytest.raises(ValueError, match="shapes differ"):
        psnr(a, a[:-1])


def test_json_writes_non_finite_numbers_as_null():
    value = {"psnr": math.inf, "rows": [np.float32(0.5), -math.inf, math.nan], "n": np.int64(3)}
    assert json.loads(json_text(value)) == {"psnr": None, "rows": [0.5, None, None], "n": 3}
    assert json_safe(value)["n"] == 3 and type(json_safe(value)["n"]) is int


def test_eval_disocclusion_psnr_is_the_shared_definition():
    rows = [{"psnr": 30.0, "disoccluded_pixels": 3, "disocclusion_l1": 0.1, "disocclusion_mse": 0.02},
            {"psnr": 31.0, "disoccluded_pixels": 1, "disocclusion_l1": 0.2, "disocclusion_mse": 0.06}]
    assert method_stats(rows)["disocclusion_psnr"] == mse_psnr((3 * 0.02 + 0.06) / 4)
    exact = [dict(r, disocclusion_mse=0.0) for r in rows]
    assert method_stats(exact)["disocclusion_psnr"] == math.inf


def test_dump_comparison_psnr_is_the_shared_definition():
    a = np.linspace(0.0, 1.0, 12, dtype=np.float32).reshape(3, 4)
    b = a.copy()
    b[0, 0] += 0.25
    stats = TensorStats()
    accumulate(stats, 0, a, entry_for("t", a), b, entry_for("t", b))
    assert stats.psnr == psnr(b, a, data_range=1.0)
    same = TensorStats()
    accumulate(same, 0, a, entry_for("t", a), a, entry_for("t", a))
    assert same.psnr == math.inf and same.as_json()["psnr"] == math.inf


def test_emulator_summary_leaves_identical_frames_out_of_the_mean():
    rows = [{"seconds": {"total": 1.0}, "psnr_db": 30.0}, {"seconds": {"total": 1.0}, "psnr_db": math.inf},
            {"seconds": {"total": 1.0}, "psnr_db": 40.0}, {"seconds": {"total": 1.0}}]
    assert summarize(rows)["mean_psnr_db"] == 35.0
