"""Backward warp: the numpy reference against analytic shifts, and the PyTorch warp against the reference."""

import numpy as np
import pytest
import torch

from mnss_kit.model import layers
from mnss_kit.ops import warp

H, W = 10, 12
ATOL = 1e-5


def nchw(a: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1)))[None]


def torch_warp(history: np.ndarray, motion: np.ndarray) -> np.ndarray:
    return layers.warp_bilinear(nchw(history), nchw(motion))[0].permute(1, 2, 0).numpy()


@pytest.fixture
def history():
    return np.random.default_rng(0).random((H, W, 3), dtype=np.float32)


def uniform(dx: float, dy: float) -> np.ndarray:
    return np.broadcast_to(np.array([dx, dy], np.float32), (H, W, 2)).copy()


def shifted(history: np.ndarray, dx: int, dy: int) -> np.ndarray:
    """Analytic integer backward shift with clamp-to-edge: out[y, x] = history[clamp(y+dy), clamp(x+dx)]."""
    ys = np.clip(np.arange(H) + dy, 0, H - 1)
    xs = np.clip(np.arange(W) + dx, 0, W - 1)
    return history[ys][:, xs]


@pytest.mark.parametrize("impl", [warp.warp_bilinear, torch_warp], ids=["numpy", "torch"])
@pytest.mark.parametrize("dx, dy", [(0, 0), (2, 1), (-1, 3), (-3, -2), (20, -20)])
def test_integer_shift(history, impl, dx, dy):
    np.testing.assert_allclose(impl(history, uniform(dx, dy)), shifted(history, dx, dy), atol=ATOL)


@pytest.mark.parametrize("impl", [warp.warp_bilinear, torch_warp], ids=["numpy", "torch"])
@pytest.mark.parametrize("dx, dy", [(0.5, 0.0), (-0.25, 0.0), (0.0, -0.75), (1.5, 0.0), (0.0, 2.25)])
def test_fractional_shift_blends_neighbours(history, impl, dx, dy):
    """A shift along one axis between two whole shifts is their linear blend (away from the edges)."""
    lo_x, lo_y = int(np.floor(dx)), int(np.floor(dy))
    a = (dx - lo_x) + (dy - lo_y)  # one of the two is zero: weight of the next whole shift
    hi_x, hi_y = lo_x + (dx != lo_x), lo_y + (dy != lo_y)
    expected = (1 - a) * shifted(history, lo_x, lo_y) + a * shifted(history, hi_x, hi_y)
    inside = (slice(3, H - 3), slice(3, W - 3))
    np.testing.assert_allclose(impl(history, uniform(dx, dy))[inside], expected[inside], atol=ATOL)


MOTIONS = {
    "zero": lambda rng: uniform(0, 0),
    "half_pixel_ties": lambda rng: uniform(0.5, -0.5),
    "negative": lambda rng: uniform(-1.25, -2.75),
    "off_screen": lambda rng: rng.uniform(-30, 30, (H, W, 2)).astype(np.float32),
    "random": lambda rng: rng.uniform(-2, 2, (H, W, 2)).astype(np.float32),
}


@pytest.mark.parametrize("case", MOTIONS)
def test_torch_warp_matches_reference(history, case):
    motion = MOTIONS[case](np.random.default_rng(3))
    np.testing.assert_allclose(torch_warp(history, motion), warp.warp_bilinear(history, motion), atol=ATOL)


def test_off_screen_samples_read_the_edge_texel(history):
    out = torch_warp(history, uniform(-100, 0))
    np.testing.assert_allclose(out, np.broadcast_to(history[:, :1], out.shape), atol=ATOL)


@pytest.mark.parametrize("scale", [2, 3])
def test_upsample_motion_matches_reference(scale):
    motion_lr = np.random.default_rng(4).uniform(-3, 3, (4, 5, 2)).astype(np.float32)
    got = layers.upsample_motion(nchw(motion_lr), scale)[0].permute(1, 2, 0).numpy()
    np.testing.assert_allclose(got, warp.upsample_motion(motion_lr, scale), atol=ATOL)
