"""The FuseSR passes on Mesa (EGL) against their numpy references: demodulation (float, within
FLOAT_ATOL), G-buffer unshuffle + pack (int8, within one code: the demodulated L it packs is a
float path, every other channel bit-exact), remodulation (display within one code), on the hard
materials (sky, emission, black metal, roughness 0 and 1), at scales 2, 3 and 4."""

from __future__ import annotations

import re

import numpy as np
import pytest
from gpu_helpers import assert_float_close

from mnss_kit.gpu import glsl
from mnss_kit.gpu.passes import PACKED_GBUFFERS
from mnss_kit.ops import brdf, colour, demodulation

H, W = 5, 7  # LR size: odd, so partial workgroups are exercised
Q = (1.0 / 255.0, -128)  # the int8 image tensor's (scale, zero point)


def materials(rng, h, w):
    """Display colour, F_beta and emissive (h, w, 3) with sky, emission, black metal, roughness 0 and 1."""
    albedo = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    metallic, rough, nv = (rng.uniform(0, 1, (h, w)).astype(np.float32) for _ in range(3))
    albedo[0], metallic[0], nv[0] = 0.0, 1.0, 1.0
    rough[1, ::2], rough[1, 1::2] = 0.0, 1.0
    fbeta = brdf.fbeta(albedo, metallic, rough, nv)
    emissive = np.zeros_like(albedo)
    fbeta[2], emissive[2] = 0.0, rng.uniform(0, 20, (w, 3))
    emissive[3] = rng.uniform(0, 50, (w, 3))
    color = colour.to_display(emissive + fbeta * rng.uniform(0, 4, (h, w, 3)))
    return color, fbeta.astype(np.float32), emissive.astype(np.float32)


def test_shader_constants_are_the_python_ones():
    text = glsl.flatten("demodulate_pass.comp")
    assert float(re.search(r"FBETA_EPSILON = ([0-9.e-]+);", text).group(1)) == demodulation.FBETA_EPSILON
    assert float(re.search(r"TONEMAP_MAX = ([0-9.e-]+);", text).group(1)) == colour.TONEMAP_MAX


@pytest.mark.parametrize("demodulate", [True, False])
def test_demodulate_matches_reference(mesa, ref, demodulate):
    c, f, e = materials(np.random.default_rng(0), H, W)
    got, want = mesa.demodulate(c, f, e, demodulate), ref.demodulate(c, f, e, demodulate)
    assert_float_close(got, want)
    assert np.isfinite(got).all()
    if not demodulate:
        assert np.array_equal(got, want)


@pytest.mark.parametrize("scale", [2, 3, 4])
@pytest.mark.parametrize("history, reset", [(False, False), (True, False), (True, True)])
@pytest.mark.parametrize("gbuffers", [PACKED_GBUFFERS, ("normal", "depth"), ()])
def test_gbuffer_pack_matches_reference_bit_for_bit(mesa, ref, scale, history, reset, gbuffers):
    rng = np.random.default_rng(scale)
    hh, hw = H * scale, W * scale
    l = rng.uniform(0, 1, (H, W, 3)).astype(np.float32)
    features = rng.uniform(0, 2, (H, W, 5)).astype(np.float32)
    warped = rng.uniform(0, 1, (hh, hw, 3)).astype(np.float32) if history else None
    images = {"fbeta": rng.uniform(0, 1, (hh, hw, 3)), "normal": rng.uniform(-1, 1, (hh, hw, 3)),
              "depth": rng.uniform(0, 1, (hh, hw, 1)), "albedo": rng.uniform(0, 1, (hh, hw, 3))}
    chosen = {g: images[g].astype(np.float32) for g in gbuffers}
    for profile in ("tflite-ref", "xnnpack"):
        args = (l, features, warped, chosen, scale, history, reset, 2.0 / 255.0, -3, profile)
        got, want = mesa.gbuffer_pack(*args), ref.gbuffer_pack(*args)
        assert got.shape == want.shape == (1, H, W, 3 + 5 + (3 * scale**2 if history else 0)
                                           + sum(3 if g != "depth" else 1 for g in gbuffers) * scale**2)
        assert np.array_equal(got, want)


@pytest.mark.parametrize("scale", [2, 4])
def test_gbuffer_pack_layout_is_pixel_unshuffle(ref, scale):
    """The packed HR channels of LR texel (i, j) are the HR tile's texels in PyTorch's order."""
    rng = np.random.default_rng(7)
    depth = rng.uniform(0, 1, (H * scale, W * scale, 1)).astype(np.float32)
    q = ref.gbuffer_pack(np.zeros((H, W, 3), np.float32), np.zeros((H, W, 1), np.float32), None, {"depth": depth},
                         scale, False, False, 1.0 / 255.0, -128, "tflite-ref")
    i, j, dy, dx = 1, 2, scale - 1, 1
    code = q[0, i, j, 4 + dy * scale + dx]
    assert code == np.clip(np.rint(depth[scale * i + dy, scale * j + dx, 0] * 255) - 128, -128, 127)


@pytest.mark.parametrize("demodulate,scale", [(True, 2), (False, 2), (True, 3)])
def test_remodulate_matches_reference(mesa, ref, demodulate, scale):
    _, f, e = materials(np.random.default_rng(3), H * scale, W * scale)
    l = np.random.default_rng(5).uniform(0, 1, (H, W, 3)).astype(np.float32)
    npu_output = np.random.default_rng(4).integers(-128, 128, (1, H * scale, W * scale, 3)).astype(np.int8)
    args = (npu_output, l, f, e, scale, 1.0 / 255.0, 0, demodulate)  # a residual in [-0.5, 0.5]
    (history, display), (want_history, want_display) = mesa.remodulate(*args), ref.remodulate(*args)
    assert_float_close(history, want_history)
    assert np.abs(display.astype(int) - want_display.astype(int)).max() <= 1
    sky = f < demodulation.FBETA_EPSILON
    if demodulate:  # F_beta 0: the emissive buffer, whatever the NPU said
        assert np.allclose(want_history[sky], colour.to_display(e)[sky], atol=2e-3)


def test_add_upsampled_torch_is_the_reference():
    import torch

    from mnss_kit.model.layers import add_upsampled

    rng = np.random.default_rng(6)
    l, residual = rng.uniform(0, 1, (H, W, 3)).astype(np.float32), rng.uniform(-0.6, 0.6, (3 * H, 3 * W, 3)).astype(np.float32)
    want = demodulation.add_upsampled(residual, l, 3)
    assert want.min() == 0.0 and want.max() == 1.0  # both clamps are exercised
    got = add_upsampled(torch.from_numpy(residual).permute(2, 0, 1)[None], torch.from_numpy(l).permute(2, 0, 1)[None], 3)
    np.testing.assert_array_equal(got[0].permute(1, 2, 0).numpy(), want)
    assert np.array_equal(want[4, 5], np.clip(l[1, 1] + residual[4, 5], 0, 1))  # HR (4, 5) reads LR (1, 1)
