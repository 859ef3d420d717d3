"""The FuseSR family: its demodulation ops against their numpy definitions, finite outputs on the
hard materials (sky, emission, black albedo, roughness 0 and 1), the split-sum LUT corner, and the
family through ``mnss-kit train`` and ``mnss-kit eval`` on a tiny rendered x4 set."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
import yaml

from mnss_kit.cli import main
from mnss_kit.errors import UserError
from mnss_kit.model import layers
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import FAMILIES, build_model, randomise_convs
from mnss_kit.model.family import example_frame
from mnss_kit.model.fusesr.config import FuseSRConfig
from mnss_kit.ops import brdf, colour, demodulation

CONFIGS = ("fusesr_x4_l", "fusesr_x4", "fusesr_x2_hybrid")
TORCH_TOLERANCE = 2e-5  # float32 pow/divide in torch against numpy, display values in [0, 1]
# At N.V = 1 and roughness 0 the GGX lobe is a mirror: A = 1, B = 0 exactly.  The integrator
# gets them to 1e-6; the 32 x 32 table read at that corner sits half a texel inside (roughness
# 1/64, N.V = 63/64), which moves A by under 1e-3.
LUT_CORNER_TOLERANCE = 1e-3


def nchw(x: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(np.moveaxis(x, -1, 0)))[None]


def test_split_sum_lut_corner_is_a_mirror():
    a, b = brdf.integrate_brdf(np.array(1.0), np.array(0.0))
    assert abs(a - 1.0) < LUT_CORNER_TOLERANCE and abs(b) < LUT_CORNER_TOLERANCE
    a, b = brdf.lookup(brdf.brdf_lut(), np.array(1.0), np.array(0.0))
    assert abs(a - 1.0) < LUT_CORNER_TOLERANCE and abs(b) < LUT_CORNER_TOLERANCE


def test_from_display_inverts_to_display_and_stays_finite():
    linear = np.array([0.0, 1e-4, 0.02, 0.5, 1.0, 7.0, 100.0], np.float32)
    assert np.allclose(colour.from_display(colour.to_display(linear)), linear, rtol=1e-3, atol=1e-6)
    assert np.isfinite(colour.from_display(np.array([1.0, 2.0, -1.0], np.float32))).all()


def _materials(rng, h=6, w=8):
    """Display colour, F_beta, emissive (h, w, 3) over the hard cases, one per row pair."""
    albedo = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    metallic = rng.uniform(0, 1, (h, w)).astype(np.float32)
    rough = rng.uniform(0, 1, (h, w)).astype(np.float32)
    nv = rng.uniform(0, 1, (h, w)).astype(np.float32)
    albedo[0], metallic[0] = 0.0, 1.0  # black metal: F_beta = B, about 0 at N.V = 1
    nv[0, : w // 2] = 1.0
    rough[1, : w // 2], rough[1, w // 2 :] = 0.0, 1.0  # mirror and fully rough
    fbeta = brdf.fbeta(albedo, metallic, rough, nv)
    emissive = np.zeros_like(albedo)
    fbeta[2], emissive[2] = 0.0, rng.uniform(0, 20, (w, 3))  # sky: radiance only, F_beta 0
    emissive[3] = rng.uniform(0, 50, (w, 3))  # bright emission on a lit surface
    radiance = rng.uniform(0, 4, (h, w, 3)).astype(np.float32)
    return colour.to_display(emissive + fbeta * radiance), fbeta.astype(np.float32), emissive.astype(np.float32), radiance


def test_demodulation_in_torch_matches_its_numpy_definition():
    c, f, e, _ = _materials(np.random.default_rng(0))
    l = demodulation.demodulate(c, f, e)
    assert np.abs(layers.demodulate(nchw(c), nchw(f), nchw(e))[0].permute(1, 2, 0).numpy() - l).max() < TORCH_TOLERANCE
    out = demodulation.remodulate(l, f, e)
    assert np.abs(layers.remodulate(nchw(l), nchw(f), nchw(e))[0].permute(1, 2, 0).numpy() - out).max() < TORCH_TOLERANCE


def test_remodulating_the_demodulated_colour_gives_the_colour_back():
    """colour = emissive + F_beta L: wherever L is defined the round trip is the identity, and where
    F_beta is about 0 (sky) the output is the emissive buffer, never a division."""
    c, f, e, _ = _materials(np.random.default_rng(1))
    back = demodulation.remodulate(demodulation.demodulate(c, f, e), f, e)
    dark = f < demodulation.FBETA_EPSILON  # the sky row, and black metal seen head-on
    assert dark.any() and (~dark).any()
    assert np.abs(back - c)[~dark].max() < 1e-4
    assert np.allclose(back[dark], colour.to_display(e)[dark], atol=1e-6)


@pytest.mark.parametrize("name", CONFIGS)
def test_no_nan_or_inf_on_sky_emission_black_albedo_and_extreme_roughness(name):
    """Forward and backward through a (randomised) model on the hard materials, at LR and HR."""
    config = load_model_config(name)
    s = config.scale
    rng = np.random.default_rng(2)
    lr, hr = _materials(rng), _materials(rng, 6 * s, 8 * s)
    model = randomise_convs(build_model(config))
    frame = example_frame(FAMILIES["fusesr"], 6, 8, s, torch.Generator().manual_seed(0))
    frame.update(color=nchw(lr[0]), lr_fbeta=nchw(lr[1]), lr_emissive=nchw(lr[2]), hr_fbeta=nchw(hr[1]),
                 hr_emissive=nchw(hr[2]), hr_albedo=torch.zeros_like(frame["hr_albedo"]))
    frame["color"].requires_grad_(True)
    output, _, state = model(frame, model.initial_state(frame))
    output2, _, _ = model(frame, state)
    (output.mean() + output2.mean()).backward()
    assert torch.isfinite(output).all() and torch.isfinite(output2).all()
    assert torch.isfinite(frame["color"].grad).all()
    assert all(torch.isfinite(p.grad).all() for p in model.parameters() if p.grad is not None)
    assert output.min() >= 0 and output.max() <= 1


def test_a_fresh_model_remodulates_the_nearest_upsampled_l():
    """The backbone starts as its skip (nearest upsample of L), so a fresh model's output is the
    remodulated, nearest-upsampled demodulated colour: the stages compose as documented."""
    config = FuseSRConfig(scale=2)
    model = build_model(config)
    frame = example_frame(FAMILIES["fusesr"], 4, 4, 2, torch.Generator().manual_seed(1))
    output, aux, _ = model(frame)
    l = layers.demodulate(frame["color"], frame["lr_fbeta"], frame["lr_emissive"])
    up = torch.nn.functional.interpolate(l, scale_factor=2, mode="nearest")
    assert torch.allclose(aux["prediction"], up.clamp(0, 1), atol=1e-6)
    assert torch.allclose(output, layers.remodulate(up, frame["hr_fbeta"], frame["hr_emissive"]), atol=1e-6)


def test_a_missing_g_buffer_is_named():
    model = build_model(FuseSRConfig(scale=2))
    frame = example_frame(FAMILIES["fusesr"], 4, 4, 2)
    del frame["hr_normal"]
    with pytest.raises(UserError, match="hr/normal"):
        model(frame)


@pytest.mark.parametrize("bad", [{"scale": 5}, {"gbuffers": ["specular"]}, {"variant": "l", "history": True}])
def test_config_refuses_what_the_family_cannot_build(bad):
    with pytest.raises(ValueError):
        FuseSRConfig(**bad)


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A tiny rendered x4 set (every G-buffer) and a fusesr_x4_l trained on it for a few steps."""
    root = tmp_path_factory.mktemp("fusesr")
    data = root / "data"
    assert main(["render", "tiny_test", "--out", str(data), "--set", "frames=3", "--set", "hr_samples=1", "--set", "scale=4",
                 "--set", "jitter=halton", "--set", "lr_size=[64,36]", "--no-progress"]) == 0
    config = root / "fusesr.yaml"
    config.write_text(yaml.safe_dump({"schema": 1, "model": {"family": "fusesr", "scale": 4, "variant": "l"}, "train": {
        "train_data": str(data), "window": 2, "batch_size": 1, "crop": 16, "epochs": 1, "steps_per_epoch": 4,
        "threads": 1, "log_every": 2, "checkpoint_every": 4, "val_every": 0, "cache_dir": str(root / "cache")}}))
    run = root / "run"
    assert main(["train", str(config), "--out", str(run), "--no-progress"]) == 0
    return {"root": root, "data": data, "ckpt": run / "model.pt"}


def test_train_writes_a_fusesr_checkpoint(trained):
    from mnss_kit.model.checkpoint import load

    model, record = load(trained["ckpt"])
    assert record["family"] == "fusesr" and model.scale == 4
    assert [s for s, _, _ in model.stages()] == ["demodulate", "encode", "unshuffle", "backbone", "remodulate"]


def test_eval_scores_the_fusesr_model_finitely_against_the_baselines(trained):
    out = trained["root"] / "eval.json"
    assert main(["eval", str(trained["ckpt"]), "--data", str(trained["data"]), "--json", str(out),
                 "--methods", "model", "bicubic", "--no-progress"]) == 0
    methods = json.loads(out.read_text())["methods"]
    assert set(methods) == {"model", "bicubic"}
    assert np.isfinite(methods["model"]["psnr"]) and np.isfinite(methods["model"]["ssim"])
