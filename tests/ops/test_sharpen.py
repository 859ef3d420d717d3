"""The unsharp enhancement kernel: reference properties, and PyTorch against the reference."""

import numpy as np
import pytest
import torch

from mnss_kit.model import layers
from mnss_kit.ops import sharpen


def test_kernel_sums_to_one_and_leaves_flat_images_alone():
    assert sharpen.unsharp_kernel().sum() == pytest.approx(1.0)
    flat = np.full((5, 6, 3), 0.4, np.float32)
    np.testing.assert_allclose(sharpen.unsharp(flat), flat, atol=1e-6)


def test_reference_boosts_a_lone_bright_pixel_and_clips():
    image = np.zeros((5, 5, 1), np.float32)
    image[2, 2] = 0.5
    out = sharpen.unsharp(image)
    assert out[2, 2, 0] == pytest.approx(0.5 * (1 + 4 * sharpen.ENHANCE_BETA))
    assert out[1, 1, 0] == 0.0  # -beta * 0.5 clipped at 0


@pytest.mark.parametrize("beta", [0.0, 0.15, 0.5])
@pytest.mark.parametrize("case", ["random", "edges", "saturated"])
def test_torch_unsharp_matches_reference(beta, case):
    rng = np.random.default_rng(0)
    image = {
        "random": rng.random((6, 7, 3), dtype=np.float32),
        "edges": np.kron(rng.integers(0, 2, (3, 4, 1)), np.ones((2, 2, 3))).astype(np.float32),
        "saturated": np.ones((4, 5, 3), np.float32) - rng.random((4, 5, 3), dtype=np.float32) * 0.01,
    }[case]
    got = layers.unsharp(torch.from_numpy(image.transpose(2, 0, 1))[None], beta)[0].permute(1, 2, 0).numpy()
    np.testing.assert_allclose(got, sharpen.unsharp(image, beta), atol=1e-6)
