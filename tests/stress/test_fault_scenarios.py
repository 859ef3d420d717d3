"""The bad-frame scenarios (``stress.scenarios.FAULTS``) on synthetic numbers and tensors: the fault
is applied to exactly one frame, recovery is counted against the clean run, NaN outputs and slow
recoveries fail, and the table shows them."""

import math

import torch

from mnss_kit.stress.run import fault_entry
from mnss_kit.stress.scenarios import FAULTS, SCENARIOS, corrupt, fault_method
from mnss_kit.stress.verdict import markdown

NAN_FRAME = next(f for f in FAULTS if f.name == "nan_frame")


def test_faults_name_a_scenario_and_their_cases():
    assert {f.name for f in FAULTS} == {"nan_frame", "inf_depth"}
    assert all(f.source in {s.name for s in SCENARIOS} for f in FAULTS)
    assert math.isnan(NAN_FRAME.value) and next(f for f in FAULTS if f.name == "inf_depth").value == math.inf


def test_fault_method_corrupts_only_the_bad_frame():
    seen = []

    def method(frame, state):
        seen.append(bool(torch.isnan(frame["color"]).any()))
        return frame["color"], {}, (state or 0) + 1

    run, state = fault_method(method, NAN_FRAME), None
    frame = {"color": torch.zeros(1, 3, 10, 10), "depth": torch.zeros(1, 1, 10, 10)}
    for _ in range(12):
        _, _, state = run(frame, state)
    assert seen == [t == NAN_FRAME.frame for t in range(12)]
    assert not torch.isnan(frame["color"]).any()  # the loader's frame is not modified
    bad = corrupt(frame, NAN_FRAME)["color"]
    assert torch.isnan(bad).sum() == 3 * 3 * 3 and torch.isnan(bad[..., 3:6, 3:6]).all()
    sky = corrupt({**frame, "hr_depth": torch.zeros(1, 1, 20, 20)}, next(f for f in FAULTS if f.name == "inf_depth"))
    assert torch.isinf(sky["depth"][..., :3, :]).all() and torch.isinf(sky["hr_depth"][..., :6, :]).all()
    assert not torch.isinf(sky["hr_depth"][..., 7:, :]).any() and not torch.isinf(sky["color"]).any()


def _rows(method, psnrs):
    return [{"frame": i, "method": method, "psnr": p} for i, p in enumerate(psnrs)]


def test_fault_entry_counts_frames_back_within_half_a_db_of_the_clean_run():
    k = NAN_FRAME.frame
    clean = [30.0] * 14
    fast = [30.0] * k + [15.0, 29.7, 30.0, 30.0, 30.0, 30.0]
    slow = [30.0] * k + [15.0, 25.0, 28.0, 29.0, 30.0, 30.0]
    nan = [30.0] * k + [math.nan] + [30.0] * 5
    rows = _rows("fast", fast) + _rows("slow", slow) + _rows("nan", nan)
    entry = fault_entry(NAN_FRAME, _rows("fast", clean) + _rows("slow", clean) + _rows("nan", clean), rows,
                        ["fast", "slow", "nan"])
    m = entry["methods"]
    assert (m["fast"]["frames_to_recover"], m["fast"]["passed"]) == (1, True)
    assert (m["slow"]["frames_to_recover"], m["slow"]["passed"]) == (4, False)
    assert m["nan"]["finite"] is False and m["nan"]["passed"] is False
    failed = fault_entry(NAN_FRAME, _rows("fast", clean), "method 'fast' produced NaN", ["fast"])
    assert failed["methods"]["fast"]["passed"] is False
    doc = {"methods": ["fast", "slow", "nan"], "scenarios": {}, "faults": {"nan_frame": entry}, "not_covered": {},
           "settings": {"recovery_tolerance_db": 0.5}}
    table = markdown(doc)
    assert "## Bad input frames" in table and "| nan_frame | slow | 4 | yes |" in table and "| NO |" in table
