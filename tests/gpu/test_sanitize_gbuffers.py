"""FuseSR's material G-buffers (F_beta, emissive, normal, albedo) with NaN and +-Inf texels: the
passes that read them (demodulate_pass, remodulate_pass, gbuffer_pack_pass) on Mesa give finite
outputs and the numpy reference's values, which are the values of the sanitized G-buffers
(``ops.sanitize.sanitize_gbuffer``: NaN -> 0, +-Inf -> +-COLOUR_MAX, finite values unchanged)."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from gpu_helpers import assert_float_close
from test_fusesr_passes import materials

from mnss_kit.gpu.passes import PACKED_GBUFFERS
from mnss_kit.model.taau import sanitize_gbuffer as torch_sanitize_gbuffer
from mnss_kit.ops.sanitize import COLOUR_MAX, sanitize_depth, sanitize_gbuffer

H, W = 5, 7


def _poison(image: np.ndarray) -> np.ndarray:
    """``image`` with NaN, +Inf and -Inf texels (whole texels and single channels)."""
    image = image.copy()
    h, w = image.shape[:2]
    image[0, 0] = np.nan
    image[h // 2, w // 2] = np.inf
    image[h - 1, w - 1] = -np.inf
    image[1, w - 2, 0] = np.nan
    image[h - 2, 1, image.shape[-1] - 1] = np.inf
    return image


def test_sanitize_gbuffer_numpy_and_torch():
    x = np.array([np.nan, -np.nan, np.inf, -np.inf, 0.0, -0.0, 0.5, -3.0, 65504, 1e30, -1e30], np.float32)
    want = np.array([0, 0, COLOUR_MAX, -COLOUR_MAX, 0.0, -0.0, 0.5, -3.0, 65504, 1e30, -1e30], np.float32)
    got = sanitize_gbuffer(x)
    assert got.dtype == np.float32 and np.array_equal(got.view(np.uint32)[4:], want.view(np.uint32)[4:])
    assert np.array_equal(got, want)
    assert np.array_equal(torch_sanitize_gbuffer(torch.from_numpy(x)).numpy().view(np.uint32), got.view(np.uint32))


@pytest.mark.parametrize("buffer", ["fbeta", "emissive"])
def test_demodulation_sanitizes_fbeta_and_emissive(gl, ref, buffer):
    """demodulate_pass (LR) and remodulate_pass (HR) with NaN / +-Inf texels in F_beta or the
    emissive buffer: finite, the reference's values (display codes within one), and the values
    of the sanitized buffer."""
    mesa, scale = gl, 2
    rng = np.random.default_rng(31)
    c, f, e = materials(rng, H, W)
    lr = {"fbeta": f, "emissive": e}
    lr[buffer] = _poison(lr[buffer])
    got, want = mesa.demodulate(c, lr["fbeta"], lr["emissive"], True), ref.demodulate(c, lr["fbeta"], lr["emissive"], True)
    assert np.all(np.isfinite(want)) and np.all(np.isfinite(got))
    assert_float_close(got, want)
    fixed = dict(lr, **{buffer: sanitize_gbuffer(lr[buffer])})
    assert np.array_equal(want, ref.demodulate(c, fixed["fbeta"], fixed["emissive"], True))
    _, f, e = materials(rng, H * scale, W * scale)
    hr = {"fbeta": f, "emissive": e}
    hr[buffer] = _poison(hr[buffer])
    npu_output = rng.integers(-128, 128, (1, H * scale, W * scale, 3)).astype(np.int8)
    args = (npu_output, want, hr["fbeta"], hr["emissive"], scale, 1.0 / 255.0, 0, True)
    (history, display), (want_history, want_display) = mesa.remodulate(*args), ref.remodulate(*args)
    assert np.all(np.isfinite(want_history)) and np.all(np.isfinite(history))
    assert_float_close(history, want_history)
    assert np.abs(display.astype(int) - want_display.astype(int)).max() <= 1


@pytest.mark.parametrize("buffer", PACKED_GBUFFERS)
def test_gbuffer_pack_sanitizes_every_gbuffer(gl, ref, buffer):
    """gbuffer_pack_pass with NaN / +-Inf texels in one HR G-buffer: the int8 NPU input bit for bit
    the reference's, which packs the sanitized values (depth: the far plane)."""
    mesa, scale = gl, 2
    rng = np.random.default_rng(37)
    hh, hw = H * scale, W * scale
    images = {"fbeta": rng.uniform(0, 1, (hh, hw, 3)), "normal": rng.uniform(-1, 1, (hh, hw, 3)),
              "depth": rng.uniform(0, 1, (hh, hw, 1)), "albedo": rng.uniform(0, 1, (hh, hw, 3))}
    clean = {g: images[g].astype(np.float32) for g in PACKED_GBUFFERS}
    bad = dict(clean, **{buffer: _poison(clean[buffer])})
    fixed = dict(clean, **{buffer: sanitize_depth(bad[buffer]) if buffer == "depth" else sanitize_gbuffer(bad[buffer])})
    l = rng.uniform(0, 1, (H, W, 3)).astype(np.float32)
    features = rng.uniform(0, 2, (H, W, 5)).astype(np.float32)
    for profile in ("tflite-ref", "xnnpack"):
        args = (l, features, None, bad, scale, False, False, 2.0 / 255.0, -3, profile)
        want = ref.gbuffer_pack(*args)
        assert np.array_equal(mesa.gbuffer_pack(*args), want)
        assert np.array_equal(want, ref.gbuffer_pack(*args[:3], fixed, *args[4:]))
