"""scripts/studies/error_breakdown.py: its pixel classes, and a model that is TAAU has TAAU's error in
every class (the side-by-side TAAU is the baseline's, frame for frame)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from mnss_kit.model.families import build_model
from mnss_kit.model.ntaau.config import NTAAUConfig

from .conftest import write_panning_sequence

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "studies" / "error_breakdown.py"


@pytest.fixture
def script(monkeypatch):
    spec = importlib.util.spec_from_file_location("error_breakdown", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)  # its dataclass looks itself up there
    spec.loader.exec_module(module)
    return module


def test_pixel_classes(script):
    weight = np.array([[0.0, 1.0, 8.0]] * 2)
    motion = np.array([[0.0, 0.5, 0.05]] * 2)
    reference = np.zeros((2, 3, 3))
    reference[:, 2] = 1.0  # a vertical step: the middle and last columns see gradients of 0.5 and 1
    labels = script.pixel_classes(weight, motion, reference)
    assert labels.tolist() == [["short|still|flat", "medium|moving|edge", "long|still|edge"]] * 2


def test_a_fresh_ntaau_model_has_taau_error_in_every_class(script, tmp_path):
    seq = write_panning_sequence(tmp_path / "pan", lr_size=(24, 16), frames=6, speed=(0.6, 0.3))
    tally = script.sequence_tally(seq, build_model(NTAAUConfig()).eval(), frames=6)
    assert sum(tally.pixels.values()) == 6 * 48 * 32
    assert any(label.startswith("short|moving") for label in tally.pixels)
    for label in tally.pixels:
        assert tally.model[label] == tally.taau[label], label
