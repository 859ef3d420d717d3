"""Calibration: range methods, the recording hook, and input checks."""

import numpy as np
import pytest
import torch

from mnss_kit.model.mnss.config import MNSSConfig

from mnss_kit.errors import UserError
from mnss_kit.ops.int8.quantize import choose_qparams, dequantize, quantize
from mnss_kit.quantize.calibrate import InputRecorder, calibrate, mse_range
from mnss_kit.quantize.run import calibration_samples


@pytest.mark.parametrize("method", ["minmax", "percentile", "entropy", "mse"])
def test_ranges_cover_zero_and_stay_inside_observed(recon, method):
    ranges = calibrate(recon.float_graph, recon.samples, method)
    assert set(ranges) == set(recon.float_graph.activations())
    for name, (lo, hi) in ranges.items():
        olo, ohi = recon.ranges[name]  # minmax
        assert olo - 1e-6 <= lo <= hi <= ohi + 1e-6, name


def test_narrower_methods_clip_outliers():
    """A heavy-tailed tensor: percentile and MSE ranges are narrower than min/max."""
    from mnss_kit.quantize.trace import trace

    class Scale(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.conv = torch.nn.Conv2d(1, 1, 1)

        def forward(self, x):
            return self.conv(x)

    m = Scale()
    with torch.no_grad():
        m.conv.weight.fill_(1.0)
        m.conv.bias.zero_()
    rng = np.random.default_rng(0)
    samples = []
    for _ in range(4):
        samples.append([rng.laplace(size=(1, 1, 128, 128)).astype(np.float32)])  # heavy tails
    g = trace(m, [torch.from_numpy(samples[0][0])])
    minmax = calibrate(g, samples, "minmax")["conv"]
    for method in ("percentile", "mse"):
        lo, hi = calibrate(g, samples, method)["conv"]
        assert hi < 0.9 * minmax[1] and lo > 0.9 * minmax[0], method


def test_mse_range_beats_minmax_on_its_own_objective():
    rng = np.random.default_rng(1)
    x = rng.laplace(size=100000).astype(np.float32)
    counts, edges = np.histogram(x, bins=2048, range=(x.min(), x.max()))
    lo, hi = mse_range((counts.astype(float), edges), (float(x.min()), float(x.max())))

    def mse(r):
        s, z = choose_qparams(*r)
        return float(np.mean((dequantize(quantize(x, s, z), s, z) - x) ** 2))

    assert mse((lo, hi)) < mse((float(x.min()), float(x.max())))


def test_calibration_samples_come_from_recurrent_runs_of_every_sequence():
    class Model(torch.nn.Module):
        """Toy recurrent model: the NPU stage sees the previous output, as MNSS's recon does."""

        config = MNSSConfig()  # the family record names the NPU stage: recon

        def __init__(self):
            super().__init__()
            self.recon = torch.nn.Conv2d(3, 3, 1)

        def stages(self):
            return [("recon", self.recon, "npu")]

        def forward(self, frame, state):
            history = torch.zeros_like(frame["color"]) if state is None else state["history"]
            out = self.recon(frame["color"] + history)
            return out, {}, {"history": out}

    class Sequence(list):
        name = "toy"

    model = Model()
    sequences = [Sequence({"color": torch.rand(1, 3, 4, 4)} for _ in range(4)) for _ in range(2)]
    samples = calibration_samples(model, sequences, 4)
    assert len(samples) == 4 and all(s[0].shape == (1, 3, 4, 4) for s in samples)
    # frames 0 and 3 of each sequence; frame 3's input carries the history of frames 0-2
    with torch.no_grad():
        _, _, state = model(sequences[1][0], None)
        for frame in sequences[1][1:3]:
            _, _, state = model(frame, state)
    np.testing.assert_allclose(samples[3][0], (sequences[1][3]["color"] + state["history"]).numpy(), atol=1e-6)
    assert not model.recon._forward_hooks  # the hook is removed afterwards
    with InputRecorder(model.recon) as rec:
        model.recon(torch.rand(1, 3, 4, 4))
    assert len(rec.samples) == 1


def test_bad_samples_are_user_errors(recon):
    good = recon.samples[0]
    bad_shape = [good[0][:, :, :8], good[1]]
    nan = [good[0].copy(), good[1]]
    nan[0][0, 0, 0, 0] = np.nan
    for samples, words in (([bad_shape], "shape"), ([nan], "NaN"), ([good[:1]], "inputs"), ([], "no calibration")):
        with pytest.raises(UserError, match=words):
            calibrate(recon.float_graph, samples, "minmax")
    with pytest.raises(UserError, match="unknown calibration method"):
        calibrate(recon.float_graph, recon.samples, "kl")
