"""The MNSS model: shapes, stages, reset, history modes, and an fx-traceable NPU part."""

import pytest
import torch
from torch import nn

from model_helpers import make_frame
from mnss_kit.errors import UserError
from mnss_kit.model import layers


@pytest.mark.parametrize("scale", [2, 3])
@pytest.mark.parametrize("recon_resolution", ["lr", "hr"])
@pytest.mark.parametrize("history", ["output", "lr_frame", "none"])
def test_forward_shapes(tiny_model, scale, recon_resolution, history):
    model = tiny_model(scale=scale, recon_resolution=recon_resolution, history=history)
    frame = make_frame(n=2, h=6, w=8)
    state = model.initial_state(frame)
    for _ in range(2):
        output, aux, state = model(frame, state)
    H, W = 6 * scale, 8 * scale
    assert output.shape == (2, 3, H, W)
    assert aux["aa"].shape == (2, 3, 6, 8)
    assert aux["weight_map"].shape == (2, 1, H, W)
    assert aux["history"].shape == (2, 3, H, W)
    assert state["history"].shape == (2, 3, H, W) and state["depth"].shape == (2, 1, 6, 8)
    assert torch.isfinite(output).all() and output.min() >= 0 and output.max() <= 1


def test_stages_in_order_with_placements(tiny_model):
    model = tiny_model(enhance=True)
    assert [(n, p) for n, _, p in model.stages()] == [
        ("warp", "gpu"), ("inpaint", "gpu"), ("aa", "gpu"), ("insert", "gpu"), ("recon", "npu"), ("enhance", "gpu")
    ]
    assert all(module.placement == placement for _, module, placement in model.stages())
    assert [n for n, _, _ in tiny_model(history="none").stages()] == ["inpaint", "aa", "insert", "recon"]


def garbage_state(model, frame, value):
    state = model.initial_state(frame)
    return {k: torch.full_like(v, value) for k, v in state.items()}


@pytest.mark.parametrize("value", [float("nan"), float("inf"), 1e30, 0.7])
def test_reset_ignores_any_history(tiny_model, value):
    model = tiny_model()
    frame = make_frame(reset=1.0)
    clean, _, _ = model(frame, None)
    output, aux, _ = model(frame, garbage_state(model, frame, value))
    assert torch.equal(output, clean)
    assert torch.equal(aux["history"], aux["upsampled"])  # rectified history is I_U
    assert torch.all(aux["weight_map"] == 1)


def test_reset_is_per_sample(tiny_model):
    model = tiny_model()
    frame = make_frame(n=2)
    frame["reset"] = torch.tensor([1.0, 0.0])
    state = garbage_state(model, frame, 0.3)
    output, _, _ = model(frame, state)
    alone = {k: v[:1] for k, v in frame.items()}
    expected, _, _ = model(alone, None)
    assert torch.allclose(output[:1], expected, atol=1e-6)
    other, _, _ = model(frame, garbage_state(model, frame, 0.9))
    assert not torch.allclose(output[1:], other[1:])  # the second sample does use its history


def test_history_is_used_without_reset(tiny_model):
    model = tiny_model()
    frame = make_frame()
    a, _, _ = model(frame, garbage_state(model, frame, 0.1))
    b, _, _ = model(frame, garbage_state(model, frame, 0.9))
    assert not torch.allclose(a, b)


def test_single_frame_ablation_ignores_state(tiny_model):
    model = tiny_model(history="none")
    frame = make_frame()
    a, _, _ = model(frame, garbage_state(model, frame, 0.1))
    b, _, _ = model(frame, garbage_state(model, frame, float("nan")))
    assert torch.equal(a, b)


def test_lr_frame_history_carries_the_upsampled_frame(tiny_model):
    model = tiny_model(history="lr_frame")
    frame = make_frame()
    _, _, state = model(frame, None)
    assert torch.equal(state["history"], layers.jittered_upsample(frame["color"], frame["jitter"], model.scale))


def test_output_history_is_the_unenhanced_output(tiny_model):
    model = tiny_model(enhance=True)
    output, aux, state = model(make_frame(), None)
    assert torch.equal(state["history"], aux["recon"])
    assert torch.allclose(output, layers.unsharp(aux["recon"], model.config.enhance_beta))


def test_warp_stage_shifts_history_by_upsampled_motion(tiny_model):
    """Uniform LR motion (1, -1) is (2, -2) HR pixels at x2: warped[y, x] = history[y - 2, x + 2]."""
    model = tiny_model()
    frame = make_frame(n=1, h=6, w=8)
    history = torch.rand(1, 3, 12, 16)
    motion = torch.tensor([1.0, -1.0]).view(1, 2, 1, 1).expand(1, 2, 6, 8)
    warped, _ = model.warp(history, torch.zeros(1, 1, 6, 8), torch.zeros(1, 2), motion)
    assert torch.allclose(warped[..., 2:, :-2], history[..., :-2, 2:], atol=1e-5)


def test_warp_stage_marks_off_screen_depth_as_the_reference_does(tiny_model):
    import numpy as np

    from mnss_kit.ops import warp as ref_warp
    from mnss_kit.ops.subpixel import jittered_upsample

    model = tiny_model()
    g = torch.Generator().manual_seed(3)
    prev_depth = torch.rand(1, 1, 6, 8, generator=g)
    motion = torch.randn(1, 2, 6, 8, generator=g) * 4.0  # some sources leave the 12x16 HR frame
    _, warped_depth = model.warp(torch.rand(1, 3, 12, 16, generator=g), prev_depth, torch.zeros(1, 2), motion)
    hr_motion = ref_warp.upsample_motion(motion[0].permute(1, 2, 0).numpy(), 2)
    hr_depth = jittered_upsample(prev_depth[0].permute(1, 2, 0).numpy(), np.zeros(2, np.float32), 2)
    want = ref_warp.warp_depth(hr_depth, hr_motion)
    off = ref_warp.offscreen(hr_motion)
    assert 0 < off.sum() < off.size
    assert torch.equal(warped_depth[0, 0] == ref_warp.OFFSCREEN_DEPTH, torch.from_numpy(off))
    assert np.allclose(warped_depth[0].permute(1, 2, 0).numpy(), want, atol=1e-5)


def test_gradients_reach_every_parameter(tiny_model):
    model = tiny_model().train()
    state = None
    loss = 0
    for t in range(2):
        output, aux, state = model(make_frame(seed=t, reset=float(t == 0)), state)
        loss = loss + output.mean() + aux["aa"].mean()
    loss.backward()
    assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in model.parameters())


@pytest.mark.parametrize("recon_resolution", ["lr", "hr"])
def test_recon_is_fx_traceable_from_npu_ops_only(tiny_model, recon_resolution):
    model = tiny_model(recon_resolution=recon_resolution)
    traced = torch.fx.symbolic_trace(model.recon)
    allowed_modules = (nn.Conv2d, nn.ReLU, nn.PixelShuffle, nn.PixelUnshuffle)
    allowed_functions = {torch.cat, torch.clamp, torch.add, __import__("operator").add}
    for node in traced.graph.nodes:
        if node.op == "call_module":
            assert isinstance(traced.get_submodule(node.target), allowed_modules), node.target
        elif node.op in ("call_function", "call_method"):
            assert node.target in allowed_functions, node.target
    x = torch.rand(1, 3, 12, 16)
    assert torch.equal(traced(x), model.recon(x))


def test_bad_frame_is_a_user_error(tiny_model):
    frame = make_frame()
    frame["depth"] = frame["depth"][..., :-1]
    with pytest.raises(UserError, match="depth"):
        tiny_model()(frame, None)
