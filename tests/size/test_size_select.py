"""The size choice on synthetic ladders: targets, budgets, the reasons a rung was passed over."""

from __future__ import annotations

import pytest

from mnss_kit.errors import UserError
from mnss_kit.size.select import Budget, Target, choose, parse_target


def rung(config, macs, psnr, if_ssim=0.99, ssim=0.95, ms=None, params=0):
    return {"config": config, "macs_per_pixel": macs, "params": params, "psnr": psnr, "ssim": ssim, "if_ssim": if_ssim,
            "device_ms": {"phone": ms} if ms is not None else {}}


LADDER = [rung("tiny", 1700, 34.0, 0.985, ms=1.0), rung("small", 3000, 34.6, 0.990, ms=2.0),
          rung("default", 7400, 34.8, 0.991, ms=4.0), rung("large", 43000, 34.9, 0.992, ms=20.0)]


def test_within_picks_the_smallest_rung_close_enough_to_the_largest():
    chosen, misses = choose(LADDER, [Target("within", 0.3)])
    assert chosen["config"] == "small"  # 0.3 dB below large; tiny is 0.9 below
    assert misses["tiny"] and not misses["small"] and not misses["large"]
    assert "0.90 dB below large" in misses["tiny"][0]
    assert choose(LADDER, [Target("within", 1.0)])[0]["config"] == "tiny"
    assert choose(LADDER, [Target("within", 0.05)])[0]["config"] == "large"


def test_floors_and_budget_all_have_to_hold():
    assert choose(LADDER, [Target("psnr", 34.7)])[0]["config"] == "default"
    assert choose(LADDER, [Target("if_ssim", 0.99)])[0]["config"] == "small"
    assert choose(LADDER, [Target("within", 0.05), Target("psnr", 34.0)], Budget("phone", 5.0))[0] is None
    chosen, misses = choose(LADDER, [Target("psnr", 34.5)], Budget("phone", 3.0))
    assert chosen["config"] == "small"
    assert misses["large"] == ["estimated 20.00 ms on phone > 3 ms"]
    assert choose(LADDER, [Target("psnr", 30)], Budget("other", 3.0))[1]["tiny"] == ["no estimate for other"]


def test_a_taau_target_compares_with_the_baseline_on_the_same_frames():
    taau = {"taau": {"psnr": 34.5}}
    chosen, misses = choose(LADDER, [Target("taau", 0.2)], baselines=taau)
    assert chosen["config"] == "default" and misses["small"] == ["PSNR +0.10 dB against TAAU (needs +0.2)"]
    assert choose(LADDER, [Target("taau", 0.0)], baselines=taau)[0]["config"] == "small"
    assert choose(LADDER, [Target("taau", 0.0)])[1]["tiny"] == ["no TAAU result to compare with"]


def test_ties_in_macs_go_to_fewer_parameters():
    ladder = [rung("wide", 3000, 34.0, params=900), rung("narrow", 3000, 34.0, params=500), rung("big", 9000, 34.1)]
    assert choose(ladder, [Target("within", 0.3)])[0]["config"] == "narrow"


def test_no_rung_meets_a_target_out_of_reach():
    chosen, misses = choose(LADDER, [Target("psnr", 40.0)])
    assert chosen is None and all(misses.values())
    with pytest.raises(UserError, match="no evaluated rung"):
        choose([], [Target("within", 0.3)])


@pytest.mark.parametrize("text, expected", [("within:0.3", Target("within", 0.3)), ("psnr:34", Target("psnr", 34.0)),
                                            ("if_ssim:0.99", Target("if_ssim", 0.99)), ("ssim:0.9", Target("ssim", 0.9)),
                                            ("taau:0", Target("taau", 0.0))])
def test_targets_parse(text, expected):
    assert parse_target(text) == expected
    assert str(parse_target(text)) == f"{expected.kind}:{expected.value:g}"


@pytest.mark.parametrize("text, message", [("0.3", "expected within:DB"), ("flip:0.1", "expected within:DB"),
                                           ("within:abc", "not a number"), ("psnr:-1", ">= 0"), ("psnr:nan", ">= 0")])
def test_bad_targets_are_one_line_errors(text, message):
    with pytest.raises(UserError, match=message):
        parse_target(text)
