"""The pure helpers of scripts/studies/quantize_study.py and scripts/studies/int8_drift.py (the scripts themselves are long runs)."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from mnss_kit.ops.warp import warp_bilinear

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts" / "studies"


def _script(name: str):
    sys.path.insert(0, str(SCRIPTS))
    try:
        spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(SCRIPTS))


study = _script("quantize_study")
drift = _script("int8_drift")


def test_ping_pong_schedule_has_no_jump():
    plan = drift.schedule(3, 14)
    assert [j for j, _ in plan] == [0, 1, 2, 3, 2, 1, 0, 1, 2, 3, 2, 1, 0, 1]
    assert all(abs(a - b) == 1 for (a, _), (b, _) in zip(plan, plan[1:]))  # every step moves one source frame
    for (prev, _), (j, backward) in zip(plan, plan[1:]):
        assert backward == (j < prev)
    assert plan[0] == (0, False)


def test_loop_period_divides_the_window_distance():
    assert drift.loop_length(42, 800) == 40  # town_test: cut at frame 42
    assert 800 % (2 * drift.loop_length(30, 800)) == 0
    with pytest.raises(SystemExit):
        drift.loop_length(1, 7)


def test_inverse_motion_undoes_a_smooth_field():
    h, w = 24, 32
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    forward = np.stack([1.5 + 0.05 * x, -0.75 + 0.02 * y], axis=-1).astype(np.float32)  # frame j+1 -> j
    inverse = drift.inverse_motion(forward, steps=6)  # frame j -> j+1
    # following the inverse and then the forward field lands back where it started (away from the clamped border)
    round_trip = inverse + warp_bilinear(forward, inverse)
    assert np.abs(round_trip[4:-4, 4:-4]).max() < 1e-3
    assert np.abs(inverse + forward).max() > 0.05  # plain negation would not do


def test_periodic_from():
    values = [5.0, 4.0, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0]
    assert study.periodic_from(values, 2) == 2
    assert study.periodic_from([1.0, 2.0, 3.0, 4.0], 2) is None


def test_target():
    assert study.meets_target({"psnr": -0.19, "ssim": -0.01, "if_ssim": -0.0019})
    assert not study.meets_target({"psnr": -0.21, "ssim": 0.0, "if_ssim": 0.0})
    assert not study.meets_target({"psnr": 0.0, "ssim": 0.0, "if_ssim": -0.0021})
    assert not study.meets_target({"psnr": 0.0, "ssim": 0.0, "if_ssim": None})
