"""Network blocks more than one family builds from."""

from __future__ import annotations

from torch import nn


def conv_stack(c_in: int, width: int, layers: int, c_out: int) -> nn.Sequential:
    """``layers`` 3x3 convs with bias and ReLU between them (none after the last).

    The hidden convs start He-normal with zero bias: with PyTorch's default (uniform weights
    and biases of the same small size) the AA net's second hidden layer died within a few
    hundred Adam steps on rendered frames, and a dead layer gets no gradient to recover.
    The last conv starts at zero, so a fresh net adds nothing to its residual base.
    """
    widths = [c_in] + [width] * (layers - 1) + [c_out]
    mods: list[nn.Module] = []
    for i in range(layers):
        mods.append(nn.Conv2d(widths[i], widths[i + 1], 3, padding=1))
        if i < layers - 1:
            nn.init.kaiming_normal_(mods[-1].weight, nonlinearity="relu")
            nn.init.zeros_(mods[-1].bias)
            mods.append(nn.ReLU())
    nn.init.zeros_(mods[-1].weight)
    nn.init.zeros_(mods[-1].bias)
    return nn.Sequential(*mods)
