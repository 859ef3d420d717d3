"""Model families by name, and building a model from its config."""

from __future__ import annotations

import math

import torch
from torch import nn

from .config import ModelConfig
from .mnss import MNSS

MODELS = {"mnss": MNSS}


def build_model(config: ModelConfig) -> nn.Module:
    """A freshly initialised model of ``config.family`` (float32, CPU)."""
    return MODELS[config.family](config)


def randomise_convs(model: nn.Module, prefixes: tuple[str, ...] = ("recon", "aa"), noise: float = 0.05) -> nn.Module:
    """Random weights for an untrained example model (tests, benchmarks, doc examples); returns ``model``.

    The convs under ``prefixes`` get weights and biases as PyTorch's Conv2d draws them by
    default (uniform within +-1/sqrt(fan_in)) plus N(0, ``noise``): every tensor carries signal
    (a fresh model's last convs are zero), quantization is not trivial, and a change to the
    model's own init does not move these numerics (a He-scaled random net amplifies int8
    rounding several times more).
    """
    with torch.no_grad():
        for name, module in model.named_modules():
            if name.startswith(prefixes) and isinstance(module, nn.Conv2d):
                bound = 1.0 / math.sqrt(module.weight[0].numel())
                for p in (module.weight, module.bias):
                    p.uniform_(-bound, bound).add_(torch.randn_like(p) * noise)
    return model
