"""Random weights for untrained test models, independent of the model's own initialisation."""

import math

import torch


def randomise_convs(model: torch.nn.Module, prefixes=("recon", "aa"), noise: float = 0.05) -> torch.nn.Module:
    """Give the convs under ``prefixes`` weights as PyTorch's Conv2d draws them by default
    (uniform within +-1/sqrt(fan_in)) plus N(0, ``noise``), so every tensor carries signal,
    quantization is not trivial, and a change to the model's init does not move the fixture's
    numerics (a He-scaled random net amplifies int8 rounding several times more)."""
    with torch.no_grad():
        for name, module in model.named_modules():
            if name.startswith(prefixes) and isinstance(module, torch.nn.Conv2d):
                bound = 1.0 / math.sqrt(module.weight[0].numel())
                for p in (module.weight, module.bias):
                    p.uniform_(-bound, bound).add_(torch.randn_like(p) * noise)
    return model
