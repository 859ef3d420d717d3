"""ntaau_lr's ``detail`` study option: the luma patch is a pixel shuffle at x2 and a continuous
patch at other scales, and a bundle refuses it (the GPU passes do not draw it).  A model given the
branch from a checkpoint without it is that checkpoint: tests/train/test_train_init.py."""

from __future__ import annotations

import pytest
import torch

from mnss_kit.errors import UserError
from mnss_kit.model.ntaau_lr.config import NTAAULRConfig
from mnss_kit.model.ntaau_lr.gpu_plan import bundle_gpu_plan
from mnss_kit.model.ntaau_lr.net import detail_luma


def test_at_x2_each_hr_pixel_takes_one_patch_value():
    raw = torch.randn(2, 4, 5, 7, generator=torch.Generator().manual_seed(1))
    want = torch.nn.functional.pixel_shuffle(0.1 * torch.tanh(raw), 2)
    assert torch.allclose(detail_luma(raw, (10, 14), 0.1), want, atol=1e-7)


def test_at_a_fractional_scale_a_flat_patch_draws_a_flat_value():
    raw = torch.full((1, 4, 6, 8), 0.5)
    out = detail_luma(raw, (9, 12), 0.2)  # 1.5x
    assert out.shape == (1, 1, 9, 12)
    assert torch.allclose(out, torch.full_like(out, 0.2 * torch.tanh(torch.tensor(0.5))), atol=1e-7)


def test_a_bundle_refuses_a_detail_model():
    with pytest.raises(UserError, match="torch-only"):
        bundle_gpu_plan(NTAAULRConfig(detail=True), {}, (16, 12), {}, "generic")
