"""ntaau_lr's ``detail`` option: the luma patch is a pixel shuffle at x2 and a continuous patch at
other scales; the branch's inputs and its patch in torch are their numpy references
(``ops.taau_lr``, which the GPU passes are held to in tests/gpu/test_taau_lr_passes.py); the
exported NPU stage has no slice; a bundle takes it at integer scales (the chain end to end:
tests/families/test_ntaau_lr.py).  A model given the branch from a checkpoint without it is that
checkpoint: tests/train/test_train_init.py."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mnss_kit.errors import UserError
from mnss_kit.model.families import build_model, randomise_convs
from mnss_kit.model.ntaau_lr.config import NTAAULRConfig
from mnss_kit.model.ntaau_lr.gpu_plan import bundle_gpu_plan, resources, schedule
from mnss_kit.model.ntaau_lr.net import branch_first_conv, detail_luma
from mnss_kit.ops import taau_lr
from mnss_kit.quantize.trace import trace
from ntaau_lr_checks import assert_close, gather_against_reference, hwc
from test_ntaau_lr import ATOL, _frames


def test_at_x2_each_hr_pixel_takes_one_patch_value():
    raw = torch.randn(2, 4, 5, 7, generator=torch.Generator().manual_seed(1))
    want = torch.nn.functional.pixel_shuffle(0.1 * torch.tanh(raw), 2)
    assert torch.allclose(detail_luma(raw, (10, 14), 0.1), want, atol=1e-7)


def test_at_a_fractional_scale_a_flat_patch_draws_a_flat_value():
    raw = torch.full((1, 4, 6, 8), 0.5)
    out = detail_luma(raw, (9, 12), 0.2)  # 1.5x
    assert out.shape == (1, 1, 9, 12)
    assert torch.allclose(out, torch.full_like(out, 0.2 * torch.tanh(torch.tensor(0.5))), atol=1e-7)


@pytest.mark.parametrize("scale", [2, 3, 4])
def test_the_patch_is_its_numpy_reference(scale):
    h, w = 5, 7
    raw = 2.0 * torch.randn(1, 4, h, w, generator=torch.Generator().manual_seed(scale))
    want = taau_lr.detail_luma(hwc(raw), (h * scale, w * scale), 0.1)
    assert want.shape == (h * scale, w * scale, 1) and np.abs(want).max() > 0.05
    assert_close(detail_luma(raw, (h * scale, w * scale), 0.1), want, ATOL)


@pytest.mark.parametrize("scale", [2, 3])
@pytest.mark.parametrize("size", [(10, 16), (9, 13)], ids=["even", "odd"])
@pytest.mark.parametrize("scale_input", [False, True], ids=["features", "scale_input"])
def test_the_detail_inputs_are_their_numpy_reference(scale, size, scale_input):
    """Gather's s x s channels of the clamped history's luma (``pixel_unshuffle`` order, after the
    scale input), padded to an even size, against ``ops.taau_lr.steering_features(detail=True)``."""
    model = build_model(NTAAULRConfig(scale=scale, detail=True, scale_input=scale_input))
    g = gather_against_reference(model, *_frames(2, *size, scale))
    assert g.want.shape == (size[0] + size[0] % 2, size[1] + size[1] % 2, model.config.npu_input_channels())
    assert np.unique(g.want[..., -scale * scale:]).size > 50
    assert_close(g.features, g.want, ATOL)


@pytest.mark.parametrize("form", ["convs", "unet"])
@pytest.mark.parametrize("reads", ["history", "all"])
def test_the_exported_net_has_no_slice_and_is_the_net(reads, form):
    """The traced NPU stage of a detail model: no op but the graph's (a slice would fail the trace),
    one concatenation of the steering and the patch, and the same function as the torch net, whether
    the branch reads the history's luma only or every input (``detail_reads``), with either form."""
    from mnss_kit.quantize.fakequant import GraphModule

    torch.manual_seed(0)
    config = NTAAULRConfig(width=8, mid_layers=1, detail=True, detail_reads=reads, detail_form=form)
    net = randomise_convs(build_model(config), noise=0.5).steer
    first = branch_first_conv(net.detail)
    assert first.in_channels == (net.c_in if reads == "all" else 0) + 4
    x = torch.rand(1, net.c_in + 4, 6, 8)
    graph = trace(net, [x])
    assert [op.kind for op in graph.ops].count("CONCATENATION") == 1 and graph.ops[-1].kind == "CONCATENATION"
    with torch.no_grad():
        want = net(x)
        got = GraphModule(graph)(x)
    got = got[0] if isinstance(got, (tuple, list)) else got
    assert want.shape == (1, 10, 6, 8) and want[:, 6:].abs().max() > 0.01
    torch.testing.assert_close(got, want, atol=1e-4, rtol=1e-4)  # float32 sums in another order; outputs reach ~170


def test_a_bundle_plan_sizes_the_boundary_for_the_detail_branch():
    config = NTAAULRConfig(scale=3, detail=True)
    words = {r["name"]: r["words"] for r in resources(config, (17, 9)) if r["kind"] == "buffer"}
    assert words == {"npu_input": -(-18 * 10 * (8 + 9) // 4), "npu_output": -(-18 * 10 * 10 // 4)}
    npu = {"model": "steer.tflite", "input": "in", "output": "out", "input_q": (0.01, 0), "output_q": (0.02, 3)}
    for filter_bound, drawn_by in ((0.25, "taau_lr_filter_pass"), (0.0, "taau_lr_accumulate_pass")):
        config = NTAAULRConfig(detail=True, detail_bound=0.2, filter_bound=filter_bound)
        steps = {s["pass"]: s["uniforms"] for s in schedule(config, (17, 9), npu, "tflite-ref")["steps"] if s["kind"] == "gpu"}
        assert steps["taau_lr_pack_pass"]["u_detail"] == {"value": 1}
        bounds = {p: u["u_detail_bound"]["value"] for p, u in steps.items() if "u_detail_bound" in u}
        assert bounds == {**dict.fromkeys(bounds, 0.0), drawn_by: 0.2}
        assert all(u["u_detail_channels"] == {"value": 4} for p, u in steps.items() if p in bounds)


def test_a_bundle_refuses_a_fractional_detail_model():
    config = NTAAULRConfig(detail=True)
    config.scale = 1.5  # the config refuses it; a plan made from one that slipped through says so too
    with pytest.raises(UserError, match="integer scales only"):
        bundle_gpu_plan(config, {}, (16, 12), {}, "generic")


def test_split_places_a_detail_models_steering_on_the_npu_as_it_is_exported():
    """``mnss-kit split`` traces the slice-free graph form (the ops the bundle's NPU graph holds),
    so the steering with a branch stays on the NPU and sends its 10 raw values across."""
    from mnss_kit.split.dataflow import npu_graph_refusal, trace_model

    model = build_model(NTAAULRConfig(detail=True))
    steer = model.steer
    flow = trace_model(model)
    stage = flow.stage("steer")
    assert npu_graph_refusal(stage) == "" and "STRIDED_SLICE" not in {op.op for op in stage.ops}
    assert [t.traced_shape[1] for t in stage.outputs] == [10]
    assert model.steer is steer  # the model is left as it was
