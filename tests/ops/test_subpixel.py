"""Sub-pixel placement: every jitter pattern and scale, the PyTorch ops against the numpy reference."""

import numpy as np
import pytest
import torch

from mnss_kit.model import layers
from mnss_kit.ops import subpixel
from mnss_kit.ops.jitter import PATTERNS, jitter_sequence, period, subpixel_index

h, w = 4, 5
CASES = [(p, s) for p in PATTERNS for s in (2, 3)] + [("halton", 4), ("center", 4)]


def jitters(pattern: str, scale: int) -> np.ndarray:
    """Every jitter of one period, as the loader hands them to the model (float32)."""
    return jitter_sequence(pattern, scale, period(pattern, scale)).astype(np.float32)


def nchw(batch_nhwc: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(batch_nhwc.transpose(0, 3, 1, 2)))


def nhwc(t: torch.Tensor) -> np.ndarray:
    return t.permute(0, 2, 3, 1).numpy()


@pytest.mark.parametrize("pattern, scale", CASES)
def test_subpixel_ops_match_reference(pattern, scale):
    """One batch mixes every jitter of the period; each sample must match the reference for its own jitter."""
    jit = jitters(pattern, scale)
    n = len(jit)
    rng = np.random.default_rng(scale)
    lr = rng.random((n, h, w, 3), dtype=np.float32)
    hr = rng.random((n, h * scale, w * scale, 3), dtype=np.float32)
    tj = torch.from_numpy(jit)
    index = layers.subpixel_index(tj, scale).numpy()
    mask = nhwc(layers.sample_mask(tj, scale, h, w))
    extracted = nhwc(layers.extract_samples(nchw(hr), tj, scale))
    inserted = nhwc(layers.insert_samples(nchw(hr), nchw(lr), tj, scale))
    upsampled = nhwc(layers.jittered_upsample(nchw(lr), tj, scale))
    for t in range(n):
        j = (float(jit[t, 0]), float(jit[t, 1]))
        np.testing.assert_array_equal(index[t], subpixel_index(np.float64(j), scale))
        np.testing.assert_array_equal(mask[t], subpixel.sample_mask(j, scale, h, w) > 0)
        np.testing.assert_array_equal(extracted[t], subpixel.extract_samples(hr[t], j, scale))
        np.testing.assert_array_equal(inserted[t], subpixel.insert_samples(hr[t], lr[t], j, scale))
        np.testing.assert_allclose(upsampled[t], subpixel.jittered_upsample(lr[t], j, scale), atol=1e-5)


@pytest.mark.parametrize("pattern, scale", CASES)
def test_insert_extract_round_trip(pattern, scale):
    jit = torch.from_numpy(jitters(pattern, scale))
    n = len(jit)
    lr = torch.rand(n, 3, h, w)
    hr = torch.rand(n, 3, h * scale, w * scale)
    assert torch.equal(layers.extract_samples(layers.insert_samples(hr, lr, jit, scale), jit, scale), lr)
    assert torch.equal(layers.insert_samples(hr, layers.extract_samples(hr, jit, scale), jit, scale), hr)
    assert torch.equal(layers.extract_samples(layers.jittered_upsample(lr, jit, scale), jit, scale), lr)


@pytest.mark.parametrize("pattern, scale", [("grid", 2), ("grid", 3)])
def test_grid_pattern_covers_the_tile(pattern, scale):
    """Over one period every HR pixel is sampled by some frame."""
    jit = torch.from_numpy(jitters(pattern, scale))
    assert layers.sample_mask(jit, scale, h, w).any(dim=0).all()


@pytest.mark.parametrize("pattern, scale", CASES)
def test_subpixel_index_agrees_in_float32_and_float64(pattern, scale):
    """Halton thirds at scale 3 and the centre pattern at even scales sit exactly on sub-pixel borders."""
    exact = jitter_sequence(pattern, scale, period(pattern, scale))
    np.testing.assert_array_equal(subpixel_index(exact, scale), subpixel_index(exact.astype(np.float32), scale))


@pytest.mark.parametrize("scale", [2, 3, 4])
def test_sample_on_a_border_goes_right_and_down(scale):
    border = np.array([1.0 / scale - 0.5, 1.0 / scale - 0.5])  # the border between sub-pixels 0 and 1
    np.testing.assert_array_equal(subpixel_index(border, scale), [1, 1])
    np.testing.assert_array_equal(layers.subpixel_index(torch.tensor(border[None], dtype=torch.float32), scale)[0].numpy(), [1, 1])
