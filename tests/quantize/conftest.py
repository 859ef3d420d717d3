"""Shared fixtures: the small modules of models.py, traced, calibrated and quantized once per session."""

import numpy as np
import pytest

from mnss_kit.quantize.calibrate import calibrate
from mnss_kit.quantize.params import quantize_graph
from mnss_kit.quantize.tflite_writer import to_tflite
from mnss_kit.quantize.trace import trace

from . import models


class Quantized:
    def __init__(self, name: str):
        self.name = name
        self.module = models.make(name)
        self.example = models.example_inputs(name)
        self.float_graph = trace(self.module, self.example)
        self.samples = [[x.numpy() for x in models.example_inputs(name, seed=s)] for s in range(6)]
        self.ranges = calibrate(self.float_graph, self.samples, "minmax")
        self.graph = quantize_graph(self.float_graph, self.ranges)
        self.tflite = to_tflite(self.graph)


@pytest.fixture(scope="session")
def recon():
    return Quantized("recon")


@pytest.fixture(scope="session")
def gates():
    return Quantized("gates")


def sqnr(reference, approx) -> float:
    return float(10 * np.log10(np.sum(reference.astype(np.float64) ** 2) / np.sum((reference - approx).astype(np.float64) ** 2)))
