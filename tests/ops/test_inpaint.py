"""ops.inpaint (numpy reference) against the model's Inpaint module and torch's conv."""

import numpy as np
import pytest
import torch

from mnss_kit.model.mnss.net import Inpaint
from mnss_kit.ops import inpaint, subpixel
from mnss_kit.ops.jitter import jitter_sequence

h, w = 5, 6


def nchw(a):
    return torch.from_numpy(np.ascontiguousarray(np.moveaxis(a, -1, 0)))[None]


def hwc(t):
    return t[0].permute(1, 2, 0).detach().numpy()


def test_conv3x3_matches_torch():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((h, w, 7)).astype(np.float32)
    weight = rng.standard_normal((5, 7, 3, 3)).astype(np.float32)
    bias = rng.standard_normal(5).astype(np.float32)
    want = torch.nn.functional.conv2d(nchw(x), torch.from_numpy(weight), torch.from_numpy(bias), padding=1)
    np.testing.assert_allclose(inpaint.conv3x3(x, weight, bias), hwc(want), atol=1e-5)


@pytest.mark.parametrize("activation", inpaint.ACTIVATIONS)
@pytest.mark.parametrize("mode", inpaint.WEIGHT_UPSAMPLES)
@pytest.mark.parametrize("scale", [2, 3])
def test_inpaint_matches_model(activation, mode, scale):
    rng = np.random.default_rng(scale)
    module = Inpaint(scale, activation, mode)
    with torch.no_grad():
        module.conv.weight.copy_(torch.from_numpy(rng.standard_normal((1, 4, 3, 3)).astype(np.float32) * 2))
        module.conv.bias.fill_(0.3)
    weight, bias = module.conv.weight.detach().numpy(), module.conv.bias.detach().numpy()
    for jitter in jitter_sequence("grid", scale, scale * scale).astype(np.float32):
        color = rng.random((h, w, 3), dtype=np.float32)
        depth = rng.random((h, w, 1), dtype=np.float32)
        warped = rng.random((h * scale, w * scale, 3), dtype=np.float32)
        warped_depth = rng.random((h * scale, w * scale, 1), dtype=np.float32)
        no_cut = torch.zeros(1, 1, 1, 1, dtype=torch.bool)
        lr_inputs = (nchw(color), nchw(depth), torch.from_numpy(jitter)[None])
        rectified, weight_map, _ = module(*lr_inputs, nchw(warped), nchw(warped_depth), no_cut)
        past = subpixel.extract_samples(warped, jitter, scale)
        past_depth = subpixel.extract_samples(warped_depth, jitter, scale)
        lr = inpaint.lr_weights(color, depth, past, past_depth, weight, bias, activation)
        m = inpaint.weight_map(lr, jitter, scale, mode)
        np.testing.assert_allclose(m, hwc(weight_map), atol=1e-6)
        up = subpixel.jittered_upsample(color, jitter, scale)
        np.testing.assert_allclose(inpaint.rectify(up, warped, m), hwc(rectified), atol=1e-6)
        assert 0 <= lr.min() and lr.max() <= 1 and lr.std() > 0.01  # a non-trivial weight map


def test_unknown_names_are_rejected():
    with pytest.raises(ValueError, match="activation"):
        inpaint.activate(np.zeros(1, np.float32), "relu")
    with pytest.raises(ValueError, match="upsampling"):
        inpaint.weight_map(np.zeros((2, 2, 1), np.float32), (0, 0), 2, "bicubic")
