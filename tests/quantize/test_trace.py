"""torch.fx tracing into the graph: the float graph computes what the module computes; bad ops are UserErrors."""

import numpy as np
import pytest
import torch
import torch.nn as nn
import torch.nn.functional as F

from mnss_kit.errors import UserError
from mnss_kit.quantize.fakequant import GraphModule
from mnss_kit.quantize.onnx_writer import to_onnx
from mnss_kit.quantize.runtime import OnnxRunner
from mnss_kit.quantize.trace import depth_perm, trace

from . import models


@pytest.mark.parametrize("name", ["recon", "gates"])
def test_float_graph_matches_module(name):
    module, xs = models.make(name), models.example_inputs(name, size=24)
    g = trace(module, xs)
    ref = module(*xs).detach().numpy()
    torch_graph = GraphModule(g)(*xs).detach().numpy()
    onnx_graph = OnnxRunner(to_onnx(g, quantize=False)).run([x.numpy().transpose(0, 2, 3, 1) for x in xs])[g.outputs[0]]
    np.testing.assert_allclose(torch_graph, ref, atol=1e-5)
    np.testing.assert_allclose(onnx_graph.transpose(0, 3, 1, 2), ref, atol=1e-5)


def test_graph_structure_of_recon():
    g = trace(models.make("recon"), models.example_inputs("recon"))
    kinds = [op.kind for op in g.ops]
    assert kinds == ["SPACE_TO_DEPTH", "CONCATENATION", "CONV_2D", "CONV_2D", "DEPTHWISE_CONV_2D", "CONCATENATION", "CONV_2D", "CONV_2D", "DEPTH_TO_SPACE", "ADD"]
    acts = [op.options.get("activation") for op in g.ops if op.kind in ("CONV_2D", "DEPTHWISE_CONV_2D", "ADD")]
    assert acts == ["relu", "relu", "relu", "none", "none", "clamp"]
    assert g.tensors[g.inputs[0]].shape == (1, 16, 16, 3)  # NHWC


def test_pixel_shuffle_permutes_the_producing_conv():
    """The conv before PixelShuffle writes DEPTH_TO_SPACE order; the conv after PixelUnshuffle reads it."""
    g = trace(models.make("recon"), models.example_inputs("recon"))
    tail = g.tensors["tail"]
    np.testing.assert_array_equal(tail.channel_order, depth_perm(np.arange(3), 2))
    assert not np.array_equal(tail.channel_order, np.arange(12))
    down = g.tensors["down"]
    np.testing.assert_array_equal(down.channel_order, depth_perm(np.arange(3), 2))
    np.testing.assert_array_equal(g.tensors["up"].channel_order, np.arange(3))


def test_depth_perm_matches_torch_pixel_unshuffle():
    from mnss_kit.quantize.fakequant import space_to_depth_dcr

    x = torch.rand(1, 3, 8, 8)
    ours = space_to_depth_dcr(x, 2)
    theirs = F.pixel_unshuffle(x, 2)
    perm = depth_perm(np.arange(3), 2)
    torch.testing.assert_close(ours, theirs[:, perm])


def test_stride2_conv_gets_explicit_pad():
    g = trace(models.make("gates"), models.example_inputs("gates"))
    pad = next(op for op in g.ops if op.kind == "PAD")
    assert pad.options["pads"] == (1, 1, 1, 1)
    conv = next(op for op in g.ops if op.inputs[0] == pad.outputs[0])
    assert conv.options["padding"] == "VALID"


class Unsupported(nn.Module):
    def __init__(self, kind):
        super().__init__()
        self.kind = kind
        self.conv = nn.Conv2d(4, 4, 3, padding=1)
        self.bn = nn.BatchNorm2d(4)
        self.grouped = nn.Conv2d(4, 4, 3, padding=1, groups=2)
        self.pool = nn.AvgPool2d(3, stride=1, padding=1)

    def forward(self, x):
        y = self.conv(x)
        if self.kind == "batchnorm":
            return self.bn(y)
        if self.kind == "sub":
            return y - x
        if self.kind == "nearest":
            return F.interpolate(y, scale_factor=2, mode="nearest")
        if self.kind == "grouped":
            return self.grouped(y)
        if self.kind == "pool_padding":
            return self.pool(y)
        if self.kind == "shuffle_input":
            return F.pixel_shuffle(torch.cat([x, x], dim=1), 2)
        if self.kind == "relu_after_cat":
            return F.relu(torch.cat([y, x], dim=1))
        if self.kind == "cat_dim":
            return torch.cat([y, x], dim=2)
        if self.kind == "control_flow":
            return y if y.sum() > 0 else x
        raise AssertionError


@pytest.mark.parametrize(
    "kind, words",
    [
        ("batchnorm", "BatchNorm2d"),
        ("sub", "sub"),
        ("nearest", "nearest"),
        ("grouped", "groups=2"),
        ("pool_padding", "count_include_pad"),
        ("shuffle_input", "PixelShuffle"),
        ("relu_after_cat", "activation"),
        ("cat_dim", "dim 2"),
        ("control_flow", "torch.fx"),
    ],
)
def test_unsupported_ops_raise_user_error(kind, words):
    with pytest.raises(UserError) as err:
        trace(Unsupported(kind), [torch.rand(1, 4, 8, 8)])
    message = str(err.value)
    assert words in message and "\n" not in message
