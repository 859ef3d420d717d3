"""Small datasets for the evaluation tests."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import torch

from mnss_kit.dataset.format import FORMAT_NAME, FORMAT_VERSION, FrameMeta, SequenceMeta, write_buffer, write_meta
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.ops.jitter import jitter_sequence


@pytest.fixture(scope="module")
def script(request):
    """The script at the test module's ``SCRIPT`` path, loaded as a module (scripts/ is no package)."""
    path = request.module.SCRIPT
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _pattern(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Display-range RGB with detail near the HR Nyquist limit (HR pixel units)."""
    r = 0.5 + 0.35 * np.sin(0.9 * x + 0.3 * y)
    g = 0.5 + 0.35 * np.cos(0.7 * y - 0.2 * x) * np.sin(0.25 * x)
    b = 0.5 + 0.3 * np.sign(np.sin(0.45 * x) * np.sin(0.45 * y))
    return np.stack([r, g, b], axis=-1).astype(np.float32)


def write_panning_sequence(out, lr_size=(32, 24), scale=2, frames=12, speed=(0.0, 0.0), pattern="grid"):
    """A flat textured plane moving ``speed`` HR pixels per frame (0 = static camera).

    Colour is stored as display values (no tone map) so the HR reference is
    exactly the 4x4 box-filtered pattern.
    """
    lw, lh = lr_size
    hw, hh = lw * scale, lh * scale
    jit = jitter_sequence(pattern, scale, frames)
    for t in range(frames):
        ox, oy = speed[0] * t, speed[1] * t  # content offset: screen point p shows pattern(p - offset)
        ly, lx = np.meshgrid(np.arange(lh) + 0.5 + jit[t][1], np.arange(lw) + 0.5 + jit[t][0], indexing="ij")
        write_buffer(out, "lr", "color", t, _pattern(lx * scale - ox, ly * scale - oy))
        write_buffer(out, "lr", "depth", t, np.full((lh, lw, 1), 0.5, np.float32))
        mv = np.empty((lh, lw, 2), np.float32)
        mv[..., 0], mv[..., 1] = -speed[0] / scale, -speed[1] / scale
        write_buffer(out, "lr", "motion", t, mv)
        acc = np.zeros((hh, hw, 3), np.float64)
        for k in range(16):
            hy, hx = np.meshgrid(np.arange(hh) + (k // 4 + 0.5) / 4, np.arange(hw) + (k % 4 + 0.5) / 4, indexing="ij")
            acc += _pattern(hx - ox, hy - oy)
        write_buffer(out, "hr", "reference", t, (acc / 16).astype(np.float32))
    meta = SequenceMeta(
        format=FORMAT_NAME, version=FORMAT_VERSION, name=out.name, scale=scale, lr_size=(lw, lh), hr_size=(hw, hh),
        jitter_pattern=pattern,
        frames=[FrameMeta(index=t, jitter=(float(jit[t][0]), float(jit[t][1])), reset=(t == 0)) for t in range(frames)],
        depth_encoding="linear", near=0.1, far=10.0, color_space="display",
    )
    write_meta(out, meta)
    return out


@pytest.fixture(scope="session")
def static_sequence(tmp_path_factory):
    return write_panning_sequence(tmp_path_factory.mktemp("static") / "static")


@pytest.fixture(scope="session")
def eval_dataset(tmp_path_factory):
    """Two short synthetic sequences (one with a camera cut) in one dataset directory."""
    root = tmp_path_factory.mktemp("evalset")
    write_synthetic_sequence(root / "pan_cut", lr_size=(24, 16), frames=8, cut_at=5, name="pan_cut")
    write_panning_sequence(root / "static", lr_size=(24, 16), frames=6)
    return root


class TinyRecurrentModel(torch.nn.Module):
    """Stands in for a trained model: follows the model interface, one 3x3 conv at HR over [upsampled, history]."""

    scale = 2

    def __init__(self):
        super().__init__()
        torch.manual_seed(0)
        self.conv = torch.nn.Conv2d(6, 3, 3, padding=1)

    def initial_state(self, frame):
        n, _, h, w = frame["color"].shape
        return {"previous": torch.zeros(n, 3, h * self.scale, w * self.scale)}

    def forward(self, frame, state):
        up = torch.nn.functional.interpolate(frame["color"], scale_factor=self.scale, mode="bilinear", align_corners=False)
        keep = (1.0 - frame["reset"]).view(-1, 1, 1, 1)
        out = (up + 0.05 * self.conv(torch.cat([up, state["previous"] * keep], dim=1))).clamp(0, 1)
        return out, {"aa": frame["color"]}, {"previous": out}


@pytest.fixture
def stand_in_model():
    """A model-shaped stand-in that needs no training code (the real MNSS is tested in test_eval_command)."""
    return TinyRecurrentModel()
