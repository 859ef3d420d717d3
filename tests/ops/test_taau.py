"""The torch TAAU (``model.taau``: the baseline and the ntaau family) against its numpy reference
``ops.taau``, step by step and over a sequence with a cut, steered and unsteered."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mnss_kit.model import taau as torch_taau
from mnss_kit.ops import taau

TOLERANCE = 2e-5  # float32 torch against the float64-accumulating reference, values in [0, 1]


def nchw(x: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(np.moveaxis(x, -1, 0)))[None]


def hwc(x: torch.Tensor) -> np.ndarray:
    return np.moveaxis(x[0].numpy(), 0, -1)


def _frame(rng, h=7, w=9):
    return (rng.uniform(0, 1, (h, w, 3)).astype(np.float32), rng.uniform(-0.5, 0.5, 2).astype(np.float32),
            rng.normal(0, 1.5, (h, w, 2)).astype(np.float32))


@pytest.mark.parametrize("scale", [2, 3])
def test_each_step_matches_the_reference(scale):
    rng = np.random.default_rng(scale)
    colour, jitter, motion = _frame(rng)
    params = torch_taau.TAAUParams()
    c, j = nchw(colour), torch.from_numpy(jitter)[None]
    np.testing.assert_allclose(hwc(torch_taau.bicubic_upsample(c, j, scale)), taau.bicubic_upsample(colour, jitter, scale), atol=TOLERANCE)
    ycc = taau.rgb_to_ycocg(colour)
    mean, weight = torch_taau.nearby_samples(nchw(ycc), j, scale, params.sample_sigma)
    ref_mean, ref_weight = taau.nearby_samples(ycc, jitter, scale, params.sample_sigma)
    np.testing.assert_allclose(hwc(mean), ref_mean, atol=TOLERANCE)
    np.testing.assert_allclose(hwc(weight), ref_weight, atol=TOLERANCE)
    for clip in ("minmax", "variance"):
        lo, hi = torch_taau.neighbourhood_box(nchw(ycc), scale, torch_taau.TAAUParams(clip=clip))
        ref_lo, ref_hi = taau.neighbourhood_box(ycc, scale, clip)
        np.testing.assert_allclose(hwc(lo), ref_lo, atol=TOLERANCE)
        np.testing.assert_allclose(hwc(hi), ref_hi, atol=TOLERANCE)
    history = rng.uniform(0, 1, (7 * scale, 9 * scale, 3)).astype(np.float32)
    hist_weight = rng.uniform(0, 9, (7 * scale, 9 * scale, 1)).astype(np.float32)
    for reset in (False, True):
        got = torch_taau.reprojected_history(nchw(history), nchw(hist_weight), torch_taau.upsample_motion(nchw(motion), scale),
                                             torch.tensor([float(reset)]), params)
        want = taau.reprojected_history(history, hist_weight, motion, reset, scale)
        np.testing.assert_allclose(hwc(got[0]), want[0], atol=TOLERANCE)
        np.testing.assert_allclose(hwc(got[1]), want[1], atol=1e-4)  # weights up to 9


@pytest.mark.parametrize("channels, still_motion_px, filter_falloff",  # 8: the display filter
                         [(6, 0.0, 0.0), (8, 0.0, 0.0), (8, 3.0, 0.0), (8, 0.0, 1.5)])
def test_a_steered_sequence_matches_the_reference(channels, still_motion_px, filter_falloff):
    """With ``still_motion_px`` the floor fades with the motion (about 3 HR pixels here, so pixels
    fall on both sides); with ``filter_falloff`` the display filter fades with the resample spread."""
    rng = np.random.default_rng(7)
    scale, h, w, bound, gain_min, filter_bound, box_bound = 2, 6, 8, 0.1, 0.75, 0.2, 1.5  # raw ~ N(0, 2): gains on both sides of the floor
    params = torch_taau.TAAUParams()
    state, ref_history, ref_weight = None, None, None
    for t in range(5):
        colour, jitter, motion = _frame(rng, h, w)
        reset = t == 2
        raw = rng.normal(0, 2, (h * scale, w * scale, channels)).astype(np.float32)
        inputs = torch_taau.taau_inputs(nchw(colour), torch.from_numpy(jitter)[None], nchw(motion), torch.tensor([float(reset)]),
                                        state, scale, params)
        floor = torch_taau.history_floor(inputs.hr_motion, gain_min, still_motion_px)
        fade = torch_taau.filter_gain(inputs.hr_motion, filter_falloff)
        out, state = torch_taau.blend(inputs, params,
                                      torch_taau.steer_from_raw(nchw(raw), bound, floor, filter_bound, box_bound, fade))

        terms = taau.current_terms(colour, jitter, scale, params.sample_sigma)
        if ref_history is None:
            history, weight = terms[2], np.zeros_like(terms[2][..., :1])  # the bicubic frame, no weight
        else:
            history, weight = taau.reprojected_history(ref_history, ref_weight, motion, reset, scale)
        ref_floor = taau.history_floor(motion, scale, gain_min, still_motion_px)
        if still_motion_px:
            np.testing.assert_allclose(hwc(floor), ref_floor, atol=1e-5)
            assert 0.0 < ref_floor.mean() < gain_min
        ref_fade = taau.filter_gain(motion, scale, filter_falloff)
        if filter_falloff:
            np.testing.assert_allclose(hwc(fade), ref_fade, atol=1e-5)
            assert ref_fade.min() < 0.8
        ref_out, ref_history, ref_weight = taau.blend(*terms, history, weight, params.prior_weight, params.max_weight,
                                                      taau.steer_from_raw(raw, bound, ref_floor, filter_bound, box_bound, ref_fade))
        np.testing.assert_allclose(hwc(out), ref_out, atol=1e-4)
        np.testing.assert_allclose(hwc(state["history"]), ref_history, atol=1e-4)
        np.testing.assert_allclose(hwc(state["weight"]), ref_weight, atol=1e-4)


def test_the_steering_features_match_the_reference():
    """The ntaau net's input as the torch model gathers it, against ``ops.taau.steering_features``
    (what the bundle's pack pass quantizes)."""
    from mnss_kit.model.families import build_model
    from mnss_kit.model.ntaau.config import NTAAUConfig

    rng = np.random.default_rng(5)
    scale, model = 2, build_model(NTAAUConfig())
    colour, jitter, motion = _frame(rng)
    state = {"history": nchw(rng.uniform(0, 1, (14, 18, 3)).astype(np.float32)),
             "weight": nchw(rng.uniform(0, 9, (14, 18, 1)).astype(np.float32))}
    inputs, features = model.taau_gather(nchw(colour), torch.from_numpy(jitter)[None], nchw(motion), torch.zeros(1), state)
    want = taau.steering_features(colour, hwc(inputs.history), hwc(inputs.history_weight), scale, model.params.max_weight)
    assert want.shape[-1] == model.config.npu_input_channels()  # what the pack pass and the bundle's buffer are sized by
    np.testing.assert_allclose(hwc(features), want, atol=TOLERANCE)
