import numpy as np
import pytest
import torch
import torch.nn.functional as F

from mnss_kit.eval.baselines import TAAU, Bicubic, baseline_methods
from mnss_kit.model.taau import rgb_to_ycocg, ycocg_to_rgb
from mnss_kit.eval.loop import evaluate

from .conftest import write_panning_sequence


def test_bicubic_without_jitter_is_torch_bicubic():
    color = torch.rand(2, 3, 8, 10)
    zero = torch.zeros(2, 2)
    expected = F.interpolate(color, scale_factor=2, mode="bicubic", align_corners=False)
    torch.testing.assert_close(Bicubic(2).upsample(color, zero), expected, atol=1e-5, rtol=0)
    torch.testing.assert_close(Bicubic(2, jitter_aware=False).upsample(color, torch.rand(2, 2)), expected)


@pytest.mark.parametrize("jitter", [(0.25, -0.25), (-0.4, 0.1)])
def test_bicubic_places_samples_where_they_were_shaded(jitter):
    """Jittered samples upsampled jitter-aware are as accurate as unjittered ones; ignoring the jitter is not."""
    s, h, w = 3, 10, 12
    f = lambda x, y: torch.sin(0.5 * x).view(1, -1) * torch.cos(0.3 * y).view(-1, 1)  # noqa: E731, LR pixel units
    truth = f((torch.arange(w * s, dtype=torch.float64) + 0.5) / s, (torch.arange(h * s, dtype=torch.float64) + 0.5) / s)
    inner = (slice(2 * s, -2 * s), slice(2 * s, -2 * s))

    def error(j, aware):
        lr = f(torch.arange(w, dtype=torch.float64) + 0.5 + j[0], torch.arange(h, dtype=torch.float64) + 0.5 + j[1])
        out = Bicubic(s, jitter_aware=aware).upsample(lr.expand(1, 3, h, w).clone(), torch.tensor([j], dtype=torch.float64))
        return float((out[0, 0][inner] - truth[inner]).abs().mean())

    centred = error((0.0, 0.0), True)  # bicubic's own interpolation error
    assert error(jitter, True) < 1.5 * centred
    assert error(jitter, False) > 4.0 * centred


def test_ycocg_round_trip():
    x = torch.rand(1, 3, 4, 5)
    torch.testing.assert_close(ycocg_to_rgb(rgb_to_ycocg(x)), x)


def _frame(color, jitter=(0.25, 0.25), reset=0.0):
    n, _, h, w = color.shape
    return {"color": color, "depth": torch.zeros(n, 1, h, w), "motion": torch.zeros(n, 2, h, w),
            "jitter": torch.tensor([jitter] * n, dtype=torch.float32), "reset": torch.full((n,), reset)}


def test_taau_reset_ignores_history():
    taau = TAAU(2)
    state = None
    rng = torch.Generator().manual_seed(0)
    for t in range(4):
        _, _, state = taau(_frame(torch.rand(1, 3, 8, 8, generator=rng), jitter=(0.25 * (-1) ** t, 0.25)), state)
    cut = _frame(torch.rand(1, 3, 8, 8, generator=rng), reset=1.0)
    after_cut, aux, _ = taau(cut, state)
    fresh, _, _ = TAAU(2)(cut, None)
    torch.testing.assert_close(after_cut, fresh)
    assert after_cut.shape == (1, 3, 16, 16) and aux == {}
    assert 0.0 <= float(after_cut.min()) and float(after_cut.max()) <= 1.0


def _mean_psnr(seq, skip=4):
    result = evaluate(baseline_methods(2), seq, progress=False)
    rows = [r for r in result["per_frame"] if r["frame"] >= skip]
    return {m: np.mean([r["psnr"] for r in rows if r["method"] == m]) for m in ("bicubic", "taau")}


def test_taau_beats_bicubic_on_a_static_camera(static_sequence):
    p = _mean_psnr(static_sequence)
    assert p["taau"] > p["bicubic"] + 3.0, p


def test_taau_beats_bicubic_on_a_slow_subpixel_pan(tmp_path):
    seq = write_panning_sequence(tmp_path / "slow", frames=10, speed=(0.37, 0.21))
    p = _mean_psnr(seq)
    assert p["taau"] > p["bicubic"] + 1.0, p
