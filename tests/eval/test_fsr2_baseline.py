"""The ``fsr2`` baseline: the numpy reference (``ops.fsr2``) behind the per-frame method interface,
run by the evaluation loop like ``taau``."""

from __future__ import annotations

import json

import numpy as np
import torch

from mnss_kit.cli import main
from mnss_kit.eval.baselines import FSR2, baseline_methods
from mnss_kit.eval.loop import evaluate
from mnss_kit.ops import fsr2

from .conftest import write_panning_sequence


def _frames(n=4, batch=2, h=9, w=11, seed=0):
    g = torch.Generator().manual_seed(seed)
    for t in range(n):
        yield {"color": torch.rand(batch, 3, h, w, generator=g), "depth": torch.rand(batch, 1, h, w, generator=g),
               "motion": torch.randn(batch, 2, h, w, generator=g) * 2, "jitter": torch.rand(batch, 2, generator=g) - 0.5,
               "reset": torch.tensor([float(t == 2), 0.0][:batch])}


def _hwc(x):
    return x.permute(1, 2, 0).numpy()


def test_each_batch_element_is_the_numpy_reference():
    """The wrapper converts layouts and nothing else: equal to ``ops.fsr2.fsr2_frame`` per element
    (tolerance 0), a reset on one element leaving the other's history alone."""
    method, state = FSR2(2, sharpness=0.3), None
    states = [None, None]
    for frame in _frames():
        output, aux, state = method(frame, state)
        assert output.shape == (2, 3, 18, 22) and aux == {}
        for i in range(2):
            want, states[i] = fsr2.fsr2_frame(_hwc(frame["color"][i]), _hwc(frame["depth"][i]), _hwc(frame["motion"][i]),
                                              frame["jitter"][i].numpy(), states[i], 2, method.params, bool(frame["reset"][i]))
            np.testing.assert_array_equal(_hwc(output[i]), want)


def test_fsr2_is_a_named_baseline():
    assert set(baseline_methods(2, ("bicubic", "taau", "fsr2"))) == {"bicubic", "taau", "fsr2"}
    assert set(baseline_methods(2)) == {"bicubic", "taau"}  # runs only when named


def _mean_psnr(seq, skip=4):
    result = evaluate(baseline_methods(2, ("bicubic", "taau", "fsr2")), seq, progress=False)
    rows = [r for r in result["per_frame"] if r["frame"] >= skip]
    return {m: np.mean([r["psnr"] for r in rows if r["method"] == m]) for m in ("bicubic", "taau", "fsr2")}


def test_fsr2_accumulates_on_a_static_camera(static_sequence):
    p = _mean_psnr(static_sequence)
    assert p["fsr2"] > p["taau"] + 3.0, p  # about +5 dB when this was written


def test_fsr2_keeps_up_with_taau_on_a_slow_subpixel_pan(tmp_path):
    seq = write_panning_sequence(tmp_path / "slow", frames=10, speed=(0.37, 0.21))
    p = _mean_psnr(seq)
    assert p["fsr2"] > p["bicubic"] + 2.0 and p["fsr2"] > p["taau"] - 0.5, p


def test_eval_runs_fsr2_when_named(eval_dataset, tmp_path):
    path = tmp_path / "s.json"
    assert main(["eval", "none", "--data", str(eval_dataset), "--methods", "taau", "fsr2", "--json", str(path),
                 "--max-frames", "3", "--no-progress"]) == 0
    assert set(json.loads(path.read_text())["methods"]) == {"taau", "fsr2"}
