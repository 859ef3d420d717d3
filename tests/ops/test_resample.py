"""The PyTorch bilinear sampling and resizing (model.layers) against the numpy reference (ops.resample)."""

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from mnss_kit.model import layers
from mnss_kit.ops import resample
from mnss_kit.ops.jitter import PATTERNS, jitter_sequence, period

ATOL = 1e-5  # float32 coordinate rounding differs between grid_sample and the reference


def nchw(image_hwc: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(image_hwc.transpose(2, 0, 1)))[None]


def hwc(tensor: torch.Tensor) -> np.ndarray:
    return tensor[0].permute(1, 2, 0).numpy()


@pytest.fixture
def image():
    return np.random.default_rng(0).random((7, 9, 3), dtype=np.float32)


# coordinate sets: exact pixel centres, texel borders (ties at .5), off-screen on every side, random
COORDINATES = {
    "centres": lambda h, w: resample.pixel_grid(h, w),
    "texel_borders": lambda h, w: tuple(c + np.float32(0.5) for c in resample.pixel_grid(h, w)),
    "off_screen": lambda h, w: (np.array([[-3.0, -0.2, w + 0.2, w + 5.0]], np.float32), np.array([[h + 4.0, -2.5, 0.1, h - 0.1]], np.float32)),
    "random": lambda h, w: tuple(np.random.default_rng(1).uniform(-2, s + 2, (5, 6)).astype(np.float32) for s in (w, h)),
}


@pytest.mark.parametrize("case", COORDINATES)
def test_bilinear_sample_matches_reference(image, case):
    x, y = COORDINATES[case](*image.shape[:2])
    expected = resample.bilinear_sample(image, x, y)
    got = layers.bilinear_sample(nchw(image), torch.from_numpy(x)[None], torch.from_numpy(y)[None])
    np.testing.assert_allclose(hwc(got), expected, atol=ATOL)


def test_reference_upsample_equals_torch_interpolate(image):
    expected = F.interpolate(nchw(image), scale_factor=3, mode="bilinear", align_corners=False)
    np.testing.assert_allclose(resample.upsample_bilinear(image, 3), hwc(expected), atol=1e-6)


@pytest.mark.parametrize("scale", [2, 3])
@pytest.mark.parametrize("pattern", PATTERNS)
def test_jittered_upsample_bilinear_matches_reference(image, pattern, scale):
    jitters = jitter_sequence(pattern, scale, period(pattern, scale)).astype(np.float32)
    batch = nchw(image).expand(len(jitters), -1, -1, -1)
    got = layers.upsample_bilinear(batch, scale, offset=torch.from_numpy(jitters))
    for t, jit in enumerate(jitters):
        expected = resample.upsample_bilinear(image, scale, offset=(float(jit[0]), float(jit[1])))
        np.testing.assert_allclose(got[t].permute(1, 2, 0).numpy(), expected, atol=ATOL)


@pytest.mark.parametrize("scale", [2, 3])
def test_avgpool_matches_reference(scale):
    image = np.random.default_rng(2).random((6 * scale, 4 * scale, 3), dtype=np.float32)
    np.testing.assert_allclose(hwc(layers.avgpool(nchw(image), scale)), resample.avgpool(image, scale), atol=1e-6)
