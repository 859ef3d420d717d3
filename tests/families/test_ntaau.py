"""The ntaau family: a fresh model is the TAAU baseline bit for bit, its steering is bounded, its
configs meet their cost limits, and its NPU stage quantizes."""

from __future__ import annotations

import math

import pytest
import torch

from mnss_kit.eval.baselines import TAAU
from mnss_kit.model import taau
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import FAMILIES, build_model, npu_module, randomise_convs
from mnss_kit.model.family import example_frame
from mnss_kit.model.macs import count_macs
from mnss_kit.model.ntaau.config import NTAAUConfig

MAC_LIMITS = {"ntaau_x2": 3000, "ntaau_x2_fast": 1500}  # per HR output pixel


def _frames(n: int, h: int = 12, w: int = 16, scale: int = 2):
    g = torch.Generator().manual_seed(3)
    frames = [example_frame(FAMILIES["ntaau"], h, w, scale, generator=g) for _ in range(n)]
    for i, f in enumerate(frames):
        f["motion"] = f["motion"] * 0.7
        f["reset"] = torch.tensor([1.0 if i == 3 else 0.0])  # a camera cut mid-sequence
    return frames


@pytest.mark.parametrize("scale", [2, 3])
def test_a_fresh_model_is_the_taau_baseline(scale):
    model, baseline = build_model(NTAAUConfig(scale=scale)), TAAU(scale)
    state = ref_state = None
    with torch.no_grad():
        for frame in _frames(6, scale=scale):
            out, aux, state = model(frame, state)
            ref, _, ref_state = baseline(frame, ref_state)
            assert torch.equal(out, ref) and torch.equal(aux["taau"], ref)


def test_the_correction_is_bounded():
    g = torch.Generator().manual_seed(0)
    colour = 0.3 + 0.4 * torch.rand(1, 3, 6, 8, generator=g)  # mid-range: nothing is clamped to [0, 1]
    frame = {"color": colour, "jitter": torch.zeros(1, 2), "motion": torch.zeros(1, 2, 6, 8)}
    params = taau.TAAUParams()
    inputs = taau.taau_inputs(colour, frame["jitter"], frame["motion"], torch.zeros(1), None, 2, params)
    neutral, _ = taau.blend(inputs, params)
    model = build_model(NTAAUConfig(correction_bound=0.05))
    raw = torch.zeros(1, 6, 12, 16)
    raw[:, 3:] = 50.0  # saturated correction, neutral gains and box
    steered, _ = model.taau_accumulate(inputs, raw)
    shift = taau.rgb_to_ycocg(steered) - taau.rgb_to_ycocg(neutral)
    torch.testing.assert_close(shift, torch.full_like(shift, 0.05), atol=1e-5, rtol=0)


def test_the_history_gain_floor_keeps_what_taau_trusts():
    """With ``history_gain_min: 1`` a net that asks for less history than TAAU gets TAAU's blend;
    one that asks for more gets it; without the floor it gets less."""
    g = torch.Generator().manual_seed(2)
    colour = 0.3 + 0.4 * torch.rand(1, 3, 6, 8, generator=g)
    params = taau.TAAUParams()
    first = taau.taau_inputs(colour, torch.zeros(1, 2), torch.zeros(1, 2, 6, 8), torch.zeros(1), None, 2, params)
    _, state = taau.blend(first, params)
    moved = 0.3 + 0.4 * torch.rand(1, 3, 6, 8, generator=g)
    inputs = taau.taau_inputs(moved, torch.full((1, 2), 0.25), torch.zeros(1, 2, 6, 8), torch.zeros(1), state, 2, params)
    neutral, _ = taau.blend(inputs, params)
    floored, unfloored = (build_model(NTAAUConfig(history_gain_min=m)) for m in (1.0, 0.0))
    less, more = torch.zeros(1, 6, 12, 16), torch.zeros(1, 6, 12, 16)
    less[:, 0], more[:, 0] = -50.0, 2.0
    torch.testing.assert_close(floored.taau_accumulate(inputs, less)[0], neutral, atol=0, rtol=0)
    assert (unfloored.taau_accumulate(inputs, less)[0] - neutral).abs().max() > 0.01
    assert (floored.taau_accumulate(inputs, more)[0] - neutral).abs().max() > 0.01
    with pytest.raises(ValueError, match="history_gain_min"):
        NTAAUConfig(history_gain_min=1.5)


def test_the_floor_holds_where_the_surface_is_still():
    """With ``still_motion_px`` the floor holds on still pixels (TAAU's blend for a net asking for
    less history) and is gone where the motion reaches it (the net's lower gain is used)."""
    g = torch.Generator().manual_seed(2)
    params = taau.TAAUParams()
    colour = 0.3 + 0.4 * torch.rand(1, 3, 6, 8, generator=g)
    first = taau.taau_inputs(colour, torch.zeros(1, 2), torch.zeros(1, 2, 6, 8), torch.zeros(1), None, 2, params)
    _, state = taau.blend(first, params)
    moved = 0.3 + 0.4 * torch.rand(1, 3, 6, 8, generator=g)
    motion = torch.zeros(1, 2, 6, 8)
    motion[..., 4:] = 1.0  # one LR pixel (two HR pixels) on the right half, still on the left
    inputs = taau.taau_inputs(moved, torch.full((1, 2), 0.25), motion, torch.zeros(1), state, 2, params)
    neutral, _ = taau.blend(inputs, params)
    less = torch.zeros(1, 6, 12, 16)
    less[:, 0] = -50.0
    faded = build_model(NTAAUConfig(history_gain_min=1.0, still_motion_px=1.0)).taau_accumulate(inputs, less)[0]
    unfloored = build_model(NTAAUConfig(history_gain_min=0.0)).taau_accumulate(inputs, less)[0]
    torch.testing.assert_close(faded[..., :4], neutral[..., :4], atol=0, rtol=0)  # still, away from the motion's edge
    torch.testing.assert_close(faded[..., 12:], unfloored[..., 12:], atol=0, rtol=0)
    assert (faded[..., 12:] - neutral[..., 12:]).abs().max() > 0.01


def test_the_correction_stays_out_of_the_history():
    """The correction changes the displayed frame only: the next history is the blend of the same
    gains and box without it, so a correction cannot build up over frames on a static camera."""
    g = torch.Generator().manual_seed(1)
    colour = 0.3 + 0.4 * torch.rand(1, 3, 6, 8, generator=g)
    params = taau.TAAUParams()
    inputs = taau.taau_inputs(colour, torch.zeros(1, 2), torch.zeros(1, 2, 6, 8), torch.zeros(1), None, 2, params)
    model = build_model(NTAAUConfig(correction_bound=0.05))
    raw = torch.randn(1, 6, 12, 16, generator=g)
    uncorrected = raw.clone()
    uncorrected[:, 3:] = 0.0
    corrected_out, corrected_state = model.taau_accumulate(inputs, raw)
    plain_out, plain_state = model.taau_accumulate(inputs, uncorrected)
    assert (corrected_out - plain_out).abs().max() > 0.01
    torch.testing.assert_close(corrected_state["history"], plain_out, atol=1e-6, rtol=0)
    torch.testing.assert_close(corrected_state["weight"], plain_state["weight"], atol=0, rtol=0)


def test_the_display_filter_is_bounded_and_stays_out_of_the_history():
    """The filter weights saturate at ``filter_bound``: a flat image passes unchanged, an impulse
    spreads by exactly the bound to each neighbour; the next history is the unfiltered blend."""
    bound = 0.2
    model = build_model(NTAAUConfig(filter_bound=bound, correction_bound=0.05))
    assert model.config.steer_channels() == 8
    raw = torch.zeros(1, 8, 12, 16)
    raw[:, 6:] = 50.0  # both weights at +bound: a blur
    impulse = torch.zeros(1, 3, 12, 16)
    impulse[..., 5, 7] = 0.5
    steer = taau.steer_from_raw(raw, 0.05, 0.0, bound)
    axis, diagonal = steer.filter_axis, steer.filter_diagonal
    spread = taau.display_filter(impulse, axis, diagonal)
    torch.testing.assert_close(spread[0, 0, 4:7, 6:9], torch.tensor([[0.1, 0.1, 0.1], [0.1, 0.5 * (1 - 8 * bound), 0.1],
                                                                     [0.1, 0.1, 0.1]]), atol=1e-6, rtol=0)
    flat = torch.full((1, 3, 12, 16), 0.4)
    torch.testing.assert_close(taau.display_filter(flat, -axis, diagonal), flat, atol=1e-6, rtol=0)
    g = torch.Generator().manual_seed(4)
    colour = 0.3 + 0.4 * torch.rand(1, 3, 6, 8, generator=g)
    inputs = taau.taau_inputs(colour, torch.zeros(1, 2), torch.zeros(1, 2, 6, 8), torch.zeros(1), None, 2, model.params)
    filtered_out, filtered_state = model.taau_accumulate(inputs, raw)
    plain_out, plain_state = model.taau_accumulate(inputs, torch.zeros_like(raw))
    assert (filtered_out - plain_out).abs().max() > 0.01
    torch.testing.assert_close(filtered_state["history"], plain_out, atol=1e-6, rtol=0)
    with pytest.raises(ValueError, match="filter_bound"):
        NTAAUConfig(filter_bound=0.3)


def test_the_display_filter_fades_where_the_history_was_resampled():
    """With ``filter_falloff`` the filter keeps its full weights where the history moved by whole
    pixels (a fetch without blur) and fades by exp(-falloff / 2) at half a pixel on both axes
    (a resample spread of 1/4 each); the same raw steering without a falloff is not faded."""
    raw = torch.zeros(1, 8, 4, 4)
    raw[:, 6:] = 50.0
    for falloff in (0.0, 1.5):
        model = build_model(NTAAUConfig(filter_bound=0.2, filter_falloff=falloff))
        motion = torch.zeros(1, 2, 2, 2)
        motion[..., 1, :] = 0.25  # LR pixels: half an HR pixel at scale 2
        inputs = taau.taau_inputs(torch.full((1, 3, 2, 2), 0.5), torch.zeros(1, 2), motion, torch.zeros(1), None, 2,
                                  model.params)
        gain = taau.filter_gain(inputs.hr_motion, falloff)
        steer = taau.steer_from_raw(raw, 0.1, 0.0, 0.2, filter_scale=gain)
        whole, half = steer.filter_axis[0, 0, 0], steer.filter_axis[0, 0, 3]
        torch.testing.assert_close(whole, torch.full((4,), 0.2))
        torch.testing.assert_close(half, torch.full((4,), 0.2 * math.exp(-falloff / 2)))
    with pytest.raises(ValueError, match="filter_falloff"):
        NTAAUConfig(filter_falloff=-1.0)


def test_the_clamp_box_widens_by_at_most_box_bound_and_narrows_to_its_centre():
    raw = torch.zeros(1, 6, 4, 4)
    raw[:, 2, :2] = 50.0
    raw[:, 2, 2:] = -50.0  # narrowing stops at the centre: -0.5
    widen = taau.steer_from_raw(raw, 0.1, 0.0, 0.0, box_bound=1.5).box_widen
    torch.testing.assert_close(widen[:, :, :2], torch.full((1, 1, 2, 4), 1.5))
    torch.testing.assert_close(widen[:, :, 2:], torch.full((1, 1, 2, 4), -0.5))
    with pytest.raises(ValueError, match="box_bound"):
        NTAAUConfig(box_bound=0.0)


@pytest.mark.parametrize("filter_bound", [0.0, 0.25])
def test_random_steering_stays_finite_and_in_range(filter_bound):
    model = randomise_convs(build_model(NTAAUConfig(filter_bound=filter_bound)), noise=2.0)
    state = None
    with torch.no_grad():
        for frame in _frames(5):
            out, _, state = model(frame, state)
            assert torch.isfinite(out).all() and out.min() >= 0.0 and out.max() <= 1.0
            assert (state["weight"] <= model.params.max_weight + 1e-6).all()


@pytest.mark.parametrize("name", sorted(MAC_LIMITS))
def test_configs_meet_their_cost_limits(name):
    macs = count_macs(build_model(load_model_config(name)))
    assert macs.total <= MAC_LIMITS[name], f"{name}: {macs.total:.0f} MACs per output pixel"


def test_the_npu_stage_quantizes():
    from mnss_kit.quantize.stage import QuantizeOptions, quantize_module

    model = randomise_convs(build_model(NTAAUConfig()))
    features = [torch.rand(1, NTAAUConfig().npu_input_channels(), 8, 10).numpy() for _ in range(4)]
    art = quantize_module(npu_module(model), [(f,) for f in features], QuantizeOptions(), name="ntaau")
    assert art.tflite[:8] and len(art.graph.ops) > 0  # the bundle: tests/families/test_family_chain.py


def test_the_bundle_schedule_hands_the_gpu_the_configs_bounds():
    """The GPU passes get every bound and floor the torch accumulation reads from the config (a
    bundle whose golden frames come from the same schedule could not catch a wrong one)."""
    from mnss_kit.model.ntaau.gpu_plan import schedule

    config = NTAAUConfig(correction_bound=0.07, box_bound=1.5, history_gain_min=0.8, still_motion_px=2.0, filter_bound=0.2)
    npu = {"model": "steer.tflite", "input": "in", "output": "out", "input_q": (0.01, 0), "output_q": (0.02, 3)}
    steps = {s["pass"]: s["uniforms"] for s in schedule(config, (16, 8), npu, "tflite-ref")["steps"] if s["kind"] == "gpu"}
    accumulate, display_filter = steps["taau_accumulate_pass"], steps["taau_filter_pass"]
    for key in ("correction_bound", "box_bound", "history_gain_min", "still_motion_px"):
        assert accumulate[f"u_{key}"] == {"value": getattr(config, key)}, key
    assert display_filter["u_filter_bound"] == {"value": config.filter_bound}
    assert display_filter["u_correction_bound"] == {"value": config.correction_bound}
