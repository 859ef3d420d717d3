"""Model families by name, and building a model from its config."""

from __future__ import annotations

from torch import nn

from .config import ModelConfig
from .mnss import MNSS

MODELS = {"mnss": MNSS}


def build_model(config: ModelConfig) -> nn.Module:
    """A freshly initialised model of ``config.family`` (float32, CPU)."""
    return MODELS[config.family](config)
