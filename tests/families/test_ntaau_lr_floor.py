"""The still-pixel history floor of the ntaau_lr family (ntaau's ``history_gain_min`` and
``still_motion_px``): the history gain after the trust gate is at least ``model.taau.history_floor``.
Torch against the numpy reference, a model with the floor on through export and the emulator, a
model without it (the default, 0) unchanged, and the shipped checkpoints trained with it."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from mnss_kit.model import taau
from mnss_kit.model.families import FAMILIES, build_model, randomise_convs
from mnss_kit.model.family import example_frame
from mnss_kit.model.ntaau_lr import net
from mnss_kit.model.ntaau_lr.config import NTAAULRConfig
from mnss_kit.ops import taau as ops_taau
from mnss_kit.ops import taau_lr
from ntaau_lr_checks import assert_close, assert_golden_frames, hwc, npu_differences

FLOOR = dict(history_gain_min=1.0, still_motion_px=1.0)


def test_the_config_validates_the_floor():
    for bad in (dict(history_gain_min=-0.1), dict(history_gain_min=1.5), dict(still_motion_px=-1.0)):
        with pytest.raises(ValueError):
            NTAAULRConfig(**bad)
    c = NTAAULRConfig()
    assert c.history_gain_min == 0.0 and c.still_motion_px == 0.0


@pytest.mark.parametrize("scale", [2, 3, 1.5])
def test_the_floored_accumulation_matches_the_numpy_reference(scale):
    """``Accumulate`` with the floor on (gain min 1 below 1 HR pixel of motion) against
    ``ops.taau.history_floor``, ``ops.taau_lr.steer_from_lr`` and ``ops.taau.blend``."""
    h, w = 8, 12
    config = NTAAULRConfig(scale=scale, box_bound=1.5, **FLOOR)
    params = taau.TAAUParams(alpha=config.alpha)
    g = torch.Generator().manual_seed(7)
    raw, trust_lr = 3.0 * torch.randn(1, 6, h, w, generator=g), torch.rand(1, 1, h, w, generator=g)
    motion = torch.randn(1, 2, h, w, generator=g)
    motion[..., : w // 2] *= 0.1  # the left half moves less than a HR pixel: the floor holds there
    colour = torch.rand(1, 3, h, w, generator=g)
    hh, hw = taau.hr_dims((h, w), scale)
    history = {"history": torch.rand(1, 3, hh, hw, generator=g),
               "weight": params.max_weight * torch.rand(1, 1, hh, hw, generator=g)}
    inputs = taau.taau_inputs(colour, torch.full((1, 2), 0.25), motion, torch.zeros(1), history, scale, params)
    out, state = net.Accumulate(params, config)(inputs, trust_lr, raw)
    hr_size = (hw, hh)
    floor = ops_taau.history_floor(hwc(motion), scale, config.history_gain_min, config.still_motion_px, hr_size)
    assert (floor > 0.5).any() and (floor == 0.0).any()
    steer = taau_lr.steer_from_lr(hwc(raw), hwc(trust_lr), scale, config.box_bound, config.filter_bound, hr_size, floor)
    terms = [hwc(getattr(inputs, k)) for k in ("samples", "sample_weight", "spatial", "lo", "hi", "history", "history_weight")]
    want_out, want_history, want_weight = ops_taau.blend(*terms, params.prior_weight, params.max_weight, steer)
    assert_close(out, want_out, 1e-4)
    assert_close(state["history"], want_history, 1e-4)
    assert_close(state["weight"], want_weight, 1e-4)
    torch_steer = net.steer_from_lr(raw, trust_lr, config, hr_size, taau.history_floor(inputs.hr_motion, **FLOOR))
    assert_close(torch_steer.history_gain, steer.history_gain, 1e-5)
    plain = taau_lr.steer_from_lr(hwc(raw), hwc(trust_lr), scale, config.box_bound, config.filter_bound, hr_size)
    assert (steer.history_gain > plain.history_gain).any()  # the floor lifted some gains
    assert (steer.history_gain >= floor - 1e-6).all()


def test_without_the_floor_a_model_is_as_it_was():
    """history_gain_min 0 (the config's default): every output as without a floor at all (the gain
    floored at -inf), bit for bit over a few frames."""
    torch.manual_seed(3)
    model = randomise_convs(build_model(NTAAULRConfig(scale=2))).eval()

    def run():
        g, state, outs = torch.Generator().manual_seed(5), None, []
        for _ in range(4):
            f = example_frame(FAMILIES["ntaau_lr"], 18, 32, 2, generator=g)
            f["motion"] = f["motion"] * 0.3
            with torch.no_grad():
                out, aux, state = model(f, state)
            outs += [out, aux["taau"], state["history"], state["weight"]]
        return outs

    floored = run()
    original = net.steer_from_lr
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(net, "steer_from_lr", lambda raw, trust_lr, config, hr_size=None, floor=0.0:
                      original(raw, trust_lr, config, hr_size, float("-inf")))
        unfloored = run()
    assert all(torch.equal(a, b) for a, b in zip(floored, unfloored))


@pytest.mark.parametrize("name", ["ntaau_lr_x2", "ntaau_lr_modes"])
def test_the_shipped_models_keep_a_still_history(name):
    """The shipped ntaau_lr checkpoints are trained with the floor their configs name."""
    from mnss_kit.model import checkpoint
    from mnss_kit.train.config import load_experiment

    model, _ = checkpoint.load(name)
    wanted = load_experiment(name)[0].model
    assert (model.config.history_gain_min, model.config.still_motion_px) == (wanted.history_gain_min, wanted.still_motion_px)
    assert model.config.history_gain_min == 1.0


# -- the bundle chain ---------------------------------------------------------------------------
LR_SIZE = (33, 19)  # (w, h): odd, the NPU tensors padded to 34x20
GOLDEN_FRAMES = 4


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    """A randomly initialised ntaau_lr model with the floor on, exported with 4 golden frames."""
    from mnss_kit.cli import main
    from mnss_kit.model import checkpoint

    w, h = LR_SIZE
    root = tmp_path_factory.mktemp("ntaau_lr_floor")
    data = root / "data"
    assert main(["render", "tiny_test", "--out", str(data), "--set", f"frames={GOLDEN_FRAMES}", "--set", "hr_samples=1",
                 "--set", f"lr_size=[{w},{h}]", "--no-progress"]) == 0
    torch.manual_seed(0)
    model = randomise_convs(build_model(NTAAULRConfig(width=8, mid_layers=1, **FLOOR)), noise=0.5)
    ckpt = checkpoint.save(root / "ntaau_lr_floor.pt", model, {"jitter_pattern": "grid"})
    out = root / "bundle"
    assert main(["export", str(ckpt), "--out", str(out), "--data", str(data), "--resolution", f"{2 * w}x{2 * h}",
                 "--golden-frames", str(GOLDEN_FRAMES), "--no-progress"]) == 0
    return {"bundle": out, "data": data}


def test_the_floor_bundle_hands_the_accumulation_the_floor(bundle):
    from mnss_kit.cli import main

    assert main(["bundle", "check", str(bundle["bundle"])]) == 0
    manifest = json.loads((bundle["bundle"] / "manifest.json").read_text())
    step = next(s for s in manifest["schedule"]["steps"] if s.get("pass") == "taau_lr_accumulate_pass")
    assert step["uniforms"]["u_history_gain_min"] == {"value": 1.0}
    assert step["uniforms"]["u_still_motion_px"] == {"value": 1.0}
    assert step["bind"]["motion"] == "motion"


@pytest.mark.parametrize("gpu_backend", ["numpy", "mesa"])
def test_the_emulator_reproduces_the_floor_bundles_golden_frames(bundle, gpu_backend):
    assert_golden_frames(bundle["bundle"], gpu_backend, GOLDEN_FRAMES)


def test_the_floor_bundles_numpy_npu_is_bit_exact(bundle):
    differing, compared = npu_differences(bundle["bundle"], bundle["data"], "tflite-ref", GOLDEN_FRAMES)
    assert compared > 0 and differing == 0
