"""The MNSS and display losses and their weight-free perceptual term."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mnss_kit.metrics.image import ssim
from mnss_kit.ops.subpixel import extract_samples as extract_samples_reference
from mnss_kit.model.losses import DisplayLoss, laplacian_pyramid, pyramid_loss
from mnss_kit.model.mnss.loss import MNSSLoss


def _images(seed: int = 0, shape=(2, 3, 24, 32)):
    g = torch.Generator().manual_seed(seed)
    return torch.rand(shape, generator=g), torch.rand(shape, generator=g)


def test_pyramid_reconstructs_and_has_bands():
    x, _ = _images()
    bands = laplacian_pyramid(x, 3)
    assert len(bands) == 4 and bands[-1].shape[-2:] == (3, 4)
    # collapsing the pyramid gives the image back (the bands are exact differences)
    image = bands[-1]
    for band in reversed(bands[:-1]):
        image = band + torch.nn.functional.interpolate(image, size=band.shape[-2:], mode="bilinear", align_corners=False)
    torch.testing.assert_close(image, x)


def test_pyramid_loss_zero_only_for_equal_images():
    a, b = _images()
    assert float(pyramid_loss(a, a)) == 0.0
    assert float(pyramid_loss(a, b)) > 0.1
    # a blurred copy is penalised more than a copy with a small brightness offset
    blurred = torch.nn.functional.avg_pool2d(a, 3, stride=1, padding=1, count_include_pad=False)
    assert float(pyramid_loss(blurred, a)) > float(pyramid_loss(a + 0.01, a))


def test_mnss_loss_terms():
    reference, output = _images(1)
    jitter = torch.tensor([[-0.25, 0.25], [0.25, -0.25]])
    aa_exact = torch.stack([
        torch.from_numpy(extract_samples_reference(reference[i].permute(1, 2, 0).numpy(), tuple(jitter[i].tolist()), 2)).permute(2, 0, 1)
        for i in range(2)
    ])
    loss = MNSSLoss(scale=2, perceptual_weight=0.1, aa_weight=5.0)
    perfect = loss(reference, {"aa": aa_exact}, {"jitter": jitter}, reference)
    assert float(perfect["total"]) < 1e-6
    parts = loss(output, {"aa": aa_exact + 0.1}, {"jitter": jitter}, reference)
    np.testing.assert_allclose(float(parts["aa"]), 0.1, rtol=1e-5)
    np.testing.assert_allclose(float(parts["ssim"]), float(1 - ssim(output, reference).mean()), rtol=1e-6)
    expected = parts["ssim"] + 0.1 * parts["perceptual"] + 5.0 * parts["aa"]
    np.testing.assert_allclose(float(parts["total"]), float(expected), rtol=1e-6)


def test_loss_gradients_reach_both_outputs():
    reference, start = _images(2)
    output = start.clone().requires_grad_(True)
    aa = torch.rand(2, 3, 12, 16, requires_grad=True)
    MNSSLoss(scale=2)(output, {"aa": aa}, {"jitter": torch.zeros(2, 2)}, reference)["total"].backward()
    assert output.grad.abs().sum() > 0 and aa.grad.abs().sum() > 0


def test_flicker_term_is_the_change_of_the_error_along_the_motion():
    loss = MNSSLoss(scale=2, flicker_weight=1.0)
    error = torch.rand(1, 3, 24, 32) - 0.5
    still = torch.zeros(1, 2, 12, 16)
    assert float(loss.flicker(error, error, still, None)) < 1e-9  # the same error every frame: no flicker
    assert float(loss.flicker(error, -error, still, None)) > 0.3  # an error that flips sign flickers
    assert float(loss.flicker(error, -error, still, torch.ones(1))) < 1e-9  # a cut has no previous frame
    # The previous error moved one LR pixel (two HR pixels) right: warping it back makes it match.
    moved = torch.roll(error, 2, dims=3)
    motion = torch.zeros(1, 2, 12, 16)
    motion[:, 0] = -1.0  # points from the current frame to where the content was
    aligned = loss.flicker(moved, error, motion, None)
    assert float(aligned) < 0.2 * float(loss.flicker(moved, error, still, None))


def test_flicker_weight_enters_the_total():
    reference, output = _images(2)
    aa = torch.rand(2, 3, 12, 16)
    jitter = torch.zeros(2, 2)
    flicker = torch.tensor(0.25)
    off = MNSSLoss(scale=2)(output, {"aa": aa}, {"jitter": jitter}, reference, None, flicker)
    on = MNSSLoss(scale=2, flicker_weight=2.0)(output, {"aa": aa}, {"jitter": jitter}, reference, None, flicker)
    np.testing.assert_allclose(float(on["total"] - off["total"]), 0.5, rtol=1e-5)
    assert float(on["flicker"]) == 0.25


def test_display_loss_mse_term_is_the_squared_error_and_enters_the_total():
    reference, output = _images(3)
    off = DisplayLoss(scale=2)(output, {}, {}, reference)
    on = DisplayLoss(scale=2, mse_weight=10.0)(output, {}, {}, reference)
    np.testing.assert_allclose(float(on["mse"]), float(((output - reference) ** 2).mean()), rtol=1e-6)
    np.testing.assert_allclose(float(on["total"] - off["total"]), 10.0 * float(on["mse"]), rtol=1e-5)
    assert tuple(on) == DisplayLoss.terms


def test_mse_weight_is_refused_where_the_loss_has_no_such_term():
    from mnss_kit.model.families import family_named
    from mnss_kit.model.mnss.config import MNSSConfig
    from mnss_kit.train.config import TrainConfig

    with pytest.raises(ValueError, match="mse_weight must be >= 0"):
        TrainConfig(mse_weight=-1.0)
    with pytest.raises(ValueError, match="mnss loss has no such term"):
        family_named("mnss").loss(MNSSConfig(), TrainConfig(mse_weight=1.0))
