import json
import math
import shutil

import numpy as np
import pytest

from mnss_kit.dataset import format as fmt
from mnss_kit.errors import UserError
from mnss_kit.eval.baselines import baseline_methods
from mnss_kit.eval.methods import model_method
from mnss_kit.eval.loop import evaluate
from mnss_kit.eval.summary import recovery

REQUIRED = ("psnr", "ssim", "if_ssim", "temporal_error")


def test_evaluate_model_and_baselines(eval_dataset, stand_in_model, tmp_path):
    result = evaluate(stand_in_model, eval_dataset, scale=2, crops_dir=tmp_path / "crops", progress=False)
    assert list(result["methods"]) == ["model", "model_nohist", "bicubic", "taau"]
    assert result["frames"] == 8 + 6
    for stats in result["methods"].values():
        for key in REQUIRED:
            assert math.isfinite(stats[key]), key
    cut = result["sequences"]["pan_cut"]
    assert cut["cuts"] == [5]
    assert len(cut["methods"]["taau"]["frames_to_recover"]) == 1
    assert cut["methods"]["taau"]["disoccluded_pixels"] > 0  # the moving square uncovers background
    rows = result["per_frame"]
    assert len(rows) == 14 * 4
    first = [r for r in rows if r["frame"] == 0 or (r["sequence"] == "pan_cut" and r["frame"] == 5)]
    assert all(math.isnan(r["if_ssim"]) for r in first)  # no IF-SSIM across a reset
    assert len(list((tmp_path / "crops").glob("*.png"))) >= 8
    json.dumps(result)  # plain data only


def test_history_ablation_differs_from_the_recurrent_model(eval_dataset, stand_in_model):
    result = evaluate(stand_in_model, eval_dataset, progress=False)
    rows = {(r["sequence"], r["frame"], r["method"]): r["psnr"] for r in result["per_frame"]}
    # identical on a reset frame (no history either way), different once history exists
    assert rows[("static", 0, "model")] == rows[("static", 0, "model_nohist")]
    assert rows[("static", 3, "model")] != rows[("static", 3, "model_nohist")]


def test_methods_dict_is_accepted_as_is(eval_dataset, stand_in_model):
    methods = {"fp32": model_method(stand_in_model), **baseline_methods(2, names=("bicubic",))}
    result = evaluate(methods, eval_dataset / "static", max_frames=3, progress=False)
    assert list(result["methods"]) == ["fp32", "bicubic"]
    assert result["frames"] == 3


def test_scale_mismatch_is_a_user_error(eval_dataset):
    with pytest.raises(UserError, match="x2 but the model is x3"):
        evaluate(baseline_methods(3), eval_dataset, scale=3, progress=False)


def test_nan_pixels_are_a_user_error(eval_dataset, tmp_path):
    seq = shutil.copytree(eval_dataset / "static", tmp_path / "static")
    meta = fmt.read_meta(seq)
    bad = np.full((meta.lr_size[1], meta.lr_size[0], 3), np.nan, np.float32)
    fmt.write_buffer(seq, "lr", "color", 2, bad)
    with pytest.raises(UserError, match="NaN"):
        evaluate(baseline_methods(2), seq, progress=False)


def test_missing_buffers_are_a_user_error(eval_dataset, tmp_path):
    seq = shutil.copytree(eval_dataset / "static", tmp_path / "static")
    meta = fmt.read_meta(seq)
    fmt.write_meta(seq, fmt.replace_meta(meta, buffers={"lr": ["color", "depth"], "hr": ["reference"]}))
    with pytest.raises(UserError, match="lr/motion"):
        evaluate(baseline_methods(2), seq, progress=False)
    fmt.write_meta(seq, meta)
    shutil.rmtree(seq / "lr" / "depth")
    with pytest.raises(UserError, match="data check: .*lr/depth: buffer directory missing"):
        evaluate(baseline_methods(2), seq, progress=False)


def test_method_needing_an_absent_buffer_is_a_user_error(eval_dataset, stand_in_model):
    def needs_albedo(frame, state):
        return frame["hr_albedo"], {}, state

    with pytest.raises(UserError, match="hr_albedo"):
        evaluate({"gbuffer": needs_albedo}, eval_dataset / "static", progress=False)


def test_recovery_counts_frames_back_to_steady_quality():
    def rows(psnrs, resets):
        return [{"psnr": p, "reset": int(i in resets)} for i, p in enumerate(psnrs)]

    steady = [30.0] * 6
    r = recovery(rows([20, 25, 29.6, 30, 30, 30] + [18, 22, 27, 29.0, 29.7] + steady, resets={0, 6}))
    assert r["warmup_frames"] == 2
    assert r["frames_to_recover"] == [4]
    never = recovery(rows([30.0] * 8 + [10.0, 11.0], resets={0, 8}))
    assert never["frames_to_recover"] == [None]


def test_frames_too_small_for_ssim_are_a_user_error(tmp_path):
    from .conftest import write_panning_sequence

    seq = write_panning_sequence(tmp_path / "tiny", lr_size=(8, 8), frames=2)
    with pytest.raises(UserError, match="too small"):
        evaluate(baseline_methods(2), seq, progress=False)
