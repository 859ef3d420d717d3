"""A random ntaau_lr model for the bundle tests, shared by the family and Android tests (a module of
its own: two conftest modules cannot both be imported)."""

import torch

from mnss_kit.model.families import build_model, randomise_convs
from mnss_kit.model.ntaau_lr.config import NTAAULRConfig
from mnss_kit.model.ntaau_lr.net import branch_last_conv


def random_ntaau_lr(**options) -> torch.nn.Module:
    """A small ntaau_lr net with random convs (seed 0).  With a detail branch the steering's and the
    branch's last convs are scaled down to raw values of a few units, as a trained net's: the two
    share the NPU output's int8 scale, and a random net's steering (hundreds) would round the patch
    to the zero point."""
    torch.manual_seed(0)
    model = randomise_convs(build_model(NTAAULRConfig(width=8, mid_layers=1, **options)), noise=0.5)
    if model.config.detail:
        with torch.no_grad():
            for p in [*model.steer.decode[-1].parameters(), *branch_last_conv(model.steer.detail).parameters()]:
                p.mul_(0.05)
    return model
