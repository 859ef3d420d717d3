"""Stress logic on synthetic numbers: recovery after a cut or pan, best/worst, the table, the scenario list."""

import math

from mnss_kit.eval.summary import frames_to_recover
from mnss_kit.render.config import load_render_config
from mnss_kit.stress.charts import write_plots
from mnss_kit.stress.run import scenario_entry
from mnss_kit.stress.scenarios import DATA_CONFIG, NOT_COVERED, SCENARIOS
from mnss_kit.stress.verdict import best_and_worst, losses_to, markdown, verdicts

WARMUP = [20.0, 25.0, 29.6, 30.0, 30.0, 30.0, 30.0, 30.0]
AFTER_CUT = [18.0, 22.0, 27.0, 29.7, 30.0, 30.0, 30.0, 30.0]


def test_recovery_counts_frames_back_within_half_a_db_after_a_synthetic_cut():
    assert frames_to_recover(WARMUP + AFTER_CUT, [len(WARMUP)]) == [2, 3]
    # a stretch that never comes back within 0.5 dB before the next event is None
    assert frames_to_recover([30.0] * 8 + [10.0, 11.0] + [30.0] * 6, [8, 10]) == [0, None, 0]
    # the tolerance is a parameter: at 0.2 dB, 29.7 is not yet back
    assert frames_to_recover(WARMUP + AFTER_CUT, [len(WARMUP)], tolerance_db=0.2) == [3, 4]


def _rows(method, psnrs, resets=(0,)):
    return [{"sequence": "fast_pan", "frame": i, "method": method, "reset": int(i in resets), "psnr": p}
            for i, p in enumerate(psnrs)]


def _info(methods, frames, cuts=()):
    stats = {"psnr": 30.0, "ssim": 0.9, "if_ssim": 0.95, "temporal_error": 0.01, "disocclusion_psnr": 20.0,
             "disocclusion_l1": 0.05, "disoccluded_pixels": 10}
    return {"frames": frames, "cuts": list(cuts), "jitter_pattern": "grid", "methods": {m: dict(stats) for m in methods}}


def test_a_pan_end_given_in_seconds_is_an_event_of_the_scenario():
    pan = next(s for s in SCENARIOS if s.name == "fast_pan")
    first_after = math.ceil(pan.events[0] * 30)  # the first frame at or after the pan's end
    psnrs = WARMUP + [30.0] * (first_after - len(WARMUP)) + AFTER_CUT
    times = [i / 30 for i in range(len(psnrs))]
    entry = scenario_entry("fast_pan", _info(["m"], len(psnrs)), _rows("m", psnrs), times, ["m"])
    assert entry["events"] == [first_after]
    assert entry["cuts"] == []
    assert entry["methods"]["m"]["frames_to_recover"] == [3]
    assert entry["per_frame_psnr"]["m"] == psnrs


def _doc():
    def stats(psnr, if_ssim, recover):
        return {"psnr": psnr, "ssim": 0.9, "if_ssim": if_ssim, "temporal_error": 0.01, "disocclusion_psnr": None,
                "disocclusion_l1": None, "disoccluded_pixels": 0, "warmup_frames": 1, "frames_to_recover": recover}

    scen = {"fast_pan": {"model": stats(31.0, 0.97, [None]), "bicubic": stats(28.0, 0.90, [0]), "taau": stats(30.0, 0.98, [4])},
            "static_camera": {"model": stats(33.0, 0.99, []), "bicubic": stats(29.0, 0.91, []), "taau": stats(32.0, 0.98, [])}}
    return {"format": "mnss-kit-stress", "version": 1, "settings": {"recovery_tolerance_db": 0.5},
            "methods": ["model", "bicubic", "taau"], "not_covered": dict(NOT_COVERED),
            "scenarios": {name: {"case": name.replace("_", " "), "frames": 4, "cuts": [], "events": [2], "jitter_pattern": "grid",
                                 "methods": m, "per_frame_psnr": {k: [28.0, 29.0, math.inf, 30.0] for k in m}}
                          for name, m in scen.items()}}


def test_best_and_worst_come_from_the_numbers_and_a_recovery_that_never_came_ranks_last():
    doc = _doc()
    ranks = verdicts(doc)
    assert ranks["fast_pan"]["PSNR"] == ("model", "bicubic")
    assert ranks["fast_pan"]["IF-SSIM"] == ("taau", "bicubic")
    assert ranks["fast_pan"]["frames to recover"] == ("bicubic", "model")
    assert "frames to recover" not in ranks["static_camera"]  # no event there
    assert "disocclusion PSNR" not in ranks["fast_pan"]  # no disocclusion measured
    assert best_and_worst({"a": {"psnr": 1.0}, "b": {"psnr": 1.0}}, "psnr", True) is None
    assert losses_to(doc, "model", "taau") == ["fast_pan: IF-SSIM 0.9700 < 0.9800"]


def test_the_table_states_verdicts_losses_to_taau_and_what_is_not_covered():
    text = markdown(_doc())
    assert "| fast_pan | model | 31.00 |" in text
    assert "never" in text
    assert "**fast_pan**" in text and "PSNR: best model (31.00), worst bicubic (28.00)" in text
    assert "model is below TAAU in: fast_pan: IF-SSIM" in text
    for name in NOT_COVERED:
        assert name in text


def test_every_scenario_has_its_sequence_in_the_stress_config_and_nothing_else_is_there():
    cfg = load_render_config(DATA_CONFIG)
    assert [s.name for s in cfg.sequences] == [s.name for s in SCENARIOS]
    assert not set(NOT_COVERED) & {s.name for s in SCENARIOS}
    by_name = {s.name: s for s in cfg.sequences}
    assert by_name["unjittered_input"].jitter == "center"
    assert by_name["particles"].particles and by_name["flickering_light"].animated_light


def test_one_per_frame_plot_per_scenario(tmp_path):
    plots = write_plots(_doc(), tmp_path)
    assert sorted(plots) == ["fast_pan", "static_camera"]
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in plots.values())
