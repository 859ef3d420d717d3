import pytest
import torch

from model_helpers import TINY, randomise
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model


@pytest.fixture
def tiny_model():
    def build(**overrides):
        torch.manual_seed(0)
        return randomise(build_model(MNSSConfig(**{**TINY, **overrides}))).eval()

    return build
