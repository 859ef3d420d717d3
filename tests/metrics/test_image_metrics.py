import math

import numpy as np
import pytest
import torch
from numpy.lib.stride_tricks import sliding_window_view

from mnss_kit.metrics.image import psnr_torch, ssim, ssim_image, ssim_map_image
from mnss_kit.metrics.psnr import psnr


def reference_ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Wang et al. 2004 written directly: full 2-D 11x11 Gaussian (sigma 1.5), float64, valid windows only."""
    c1, c2 = 0.01**2, 0.03**2
    d = np.arange(11) - 5.0
    g2 = np.exp(-(d[:, None] ** 2 + d[None, :] ** 2) / (2 * 1.5**2))
    g2 /= g2.sum()
    vals = []
    for ch in range(a.shape[2]):
        x, y = a[..., ch].astype(np.float64), b[..., ch].astype(np.float64)
        f = lambda z: np.einsum("ijkl,kl->ij", sliding_window_view(z, (11, 11)), g2)  # noqa: E731
        mx, my = f(x), f(y)
        vx, vy, cxy = f(x * x) - mx * mx, f(y * y) - my * my, f(x * y) - mx * my
        s = ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2))
        vals.append(s.mean())
    return float(np.mean(vals))


def test_psnr_identical_is_inf_and_known_value():
    img = np.random.default_rng(0).random((8, 9, 3))
    assert psnr(img, img) == math.inf
    # constant error 0.1 -> MSE 0.01 -> 20 dB
    assert psnr(img, img + 0.1) == pytest.approx(20.0, abs=1e-9)
    t = torch.from_numpy(img).permute(2, 0, 1)[None]
    assert float(psnr_torch(t + 0.1, t)[0]) == pytest.approx(20.0, abs=1e-6)


def test_ssim_identical_is_one():
    img = np.random.default_rng(1).random((20, 24, 3)).astype(np.float32)
    assert ssim_image(img, img) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ssim_matches_direct_formula(seed):
    rng = np.random.default_rng(seed)
    a = rng.random((31, 40, 3)).astype(np.float32)
    b = np.clip(a + rng.normal(0, 0.15, a.shape), 0, 1).astype(np.float32)
    assert ssim_image(a, b) == pytest.approx(reference_ssim(a, b), abs=1e-4)
    assert ssim_image(a, b) < 0.9


def test_ssim_torch_is_differentiable_and_batched():
    a = torch.rand(2, 3, 16, 16, requires_grad=True)
    b = torch.rand(2, 3, 16, 16)
    s = ssim(a, b)
    assert s.shape == (2,)
    (1 - s).sum().backward()
    assert a.grad is not None and torch.isfinite(a.grad).all()


def test_ssim_map_shape_and_small_image_error():
    a = np.zeros((20, 30, 3), np.float32)
    assert ssim_map_image(a, a).shape == (10, 20)
    with pytest.raises(ValueError):
        ssim_image(np.zeros((8, 8, 3)), np.zeros((8, 8, 3)))


def test_flip_zero_for_identical_and_positive_for_different():
    from mnss_kit.metrics.flip import flip_error

    img = np.random.default_rng(3).random((24, 24, 3)).astype(np.float32)
    assert flip_error(img, img) == pytest.approx(0.0, abs=1e-6)
    assert flip_error(np.clip(img + 0.2, 0, 1), img) > 0.05
