"""The ntaau_lr family: a fresh model is the TAAU baseline bit for bit, each of its own steps in
torch is its numpy reference (``ops.taau_lr``; the GLSL passes are held to the same reference in
tests/gpu/test_taau_lr_passes.py), and a randomly initialised model goes through the bundle chain:
export, bundle check, emulation bit-exact to every runtime; so does one with a detail branch."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from mnss_kit.eval.baselines import TAAU
from mnss_kit.model import taau
from mnss_kit.model.families import FAMILIES, build_model, randomise_convs
from mnss_kit.model.family import example_frame
from mnss_kit.model.ntaau_lr import net
from mnss_kit.model.ntaau_lr.config import NTAAULRConfig
from mnss_kit.ops import taau as ops_taau
from mnss_kit.ops import taau_lr
from ntaau_lr_checks import assert_close, assert_golden_frames, gather_against_reference, hwc, npu_differences
from random_ntaau_lr import random_ntaau_lr


ATOL = 1e-5  # torch and numpy, float32 in a different order


def _frames(n: int, h: int = 18, w: int = 32, scale: int = 2, seed: int = 3):
    g = torch.Generator().manual_seed(seed)
    frames = [example_frame(FAMILIES["ntaau_lr"], h, w, scale, generator=g) for _ in range(n)]
    for i, f in enumerate(frames):
        f["motion"] = f["motion"] * 0.7
        f["depth"] = 0.2 + 0.6 * f["depth"]
        f["reset"] = torch.tensor([1.0 if i == 3 else 0.0])  # a camera cut mid-sequence
    return frames



def _nchw(x: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(np.moveaxis(np.asarray(x, np.float32), -1, 0)))[None]


def _close(got: torch.Tensor, want: np.ndarray, atol: float = ATOL) -> None:
    assert_close(got, want, atol)


@pytest.mark.parametrize("scale", [2, 3])
def test_a_fresh_model_is_the_taau_baseline(scale):
    model, baseline = build_model(NTAAULRConfig(scale=scale)), TAAU(scale)
    state = ref_state = None
    with torch.no_grad():
        for frame in _frames(5, 9, 13, scale):
            out, aux, state = model(frame, state)
            ref, _, ref_state = baseline(frame, ref_state)
            assert torch.equal(out, ref) and torch.equal(aux["taau"], ref)


@pytest.mark.parametrize("size", [(18, 32), (19, 33)], ids=["even", "odd"])
def test_evidence_matches_the_numpy_reference(size):
    f = _frames(1, *size)[0]
    previous = 0.2 + 0.6 * torch.rand(1, 1, *size, generator=torch.Generator().manual_seed(5))
    config = NTAAULRConfig()
    change, spread = net.depth_change(f["depth"], previous, f["motion"]), net.motion_spread(f["motion"])
    want_change = taau_lr.depth_change(hwc(f["depth"]), hwc(previous), hwc(f["motion"]))
    want_spread = taau_lr.motion_spread(hwc(f["motion"]))
    _close(change, want_change)
    _close(spread, want_spread)
    _close(net.trust(change, spread, config), taau_lr.trust(want_change, want_spread, config.trust_depth, config.trust_spread_px))
    assert (want_change > 0.1).any() and (want_change < -0.1).any()


@pytest.mark.parametrize("size", [(18, 32), (19, 33)], ids=["even", "odd"])
def test_the_gather_matches_the_numpy_reference(size):
    """The 8 features, padded to an even size, and the trust map of ``Gather`` against ``ops.taau_lr``
    on a frame with a reprojected history."""
    model = build_model(NTAAULRConfig())
    g = gather_against_reference(model, *_frames(2, *size))
    assert g.want.shape == (size[0] + size[0] % 2, size[1] + size[1] % 2, 8)
    _close(g.features, g.want)
    c = model.config
    _close(g.trust_lr, taau_lr.trust(g.change, g.spread, c.trust_depth, c.trust_spread_px))


@pytest.mark.parametrize("scale", [2, 3])
def test_the_steering_upsample_and_the_fallback_blend_match_the_numpy_reference(scale):
    """``steer_from_lr`` (bilinear LR -> HR, the trust gating, the mapping) and ``blend`` with a
    fallback, torch against ``ops.taau_lr`` / ``ops.taau``; the raw values span the saturated ranges."""
    h, w = 7, 11
    config = NTAAULRConfig(scale=scale, box_bound=1.5, filter_bound=0.2)
    g = torch.Generator().manual_seed(scale)
    raw, trust_lr = 3.0 * torch.randn(1, 6, h, w, generator=g), torch.rand(1, 1, h, w, generator=g)
    steer = net.steer_from_lr(raw, trust_lr, config)
    want = taau_lr.steer_from_lr(hwc(raw), hwc(trust_lr), scale, config.box_bound, config.filter_bound)
    for name in ("history_gain", "sample_gain", "box_widen", "fallback", "filter_axis", "filter_diagonal"):
        _close(getattr(steer, name), getattr(want, name))
    assert (want.fallback > 0.5).any() and (want.fallback == 0.0).any()
    params = taau.TAAUParams()
    colour = torch.rand(1, 3, h, w, generator=g)
    history = {"history": torch.rand(1, 3, h * scale, w * scale, generator=g),
               "weight": params.max_weight * torch.rand(1, 1, h * scale, w * scale, generator=g)}
    inputs = taau.taau_inputs(colour, torch.full((1, 2), 0.25), torch.randn(1, 2, h, w, generator=g), torch.zeros(1),
                              history, scale, params)
    out, state = taau.blend(inputs, params, steer)
    terms = [hwc(getattr(inputs, k)) for k in ("samples", "sample_weight", "spatial", "lo", "hi", "history", "history_weight")]
    want_out, want_history, want_weight = ops_taau.blend(*terms, params.prior_weight, params.max_weight, want)
    _close(out, want_out, 1e-4)
    _close(state["history"], want_history, 1e-4)
    _close(state["weight"], want_weight, 1e-4)


def test_full_fallback_gives_the_bicubic_frame_and_drops_the_history():
    params = taau.TAAUParams()
    g = torch.Generator().manual_seed(1)
    colour = 0.3 + 0.4 * torch.rand(1, 3, 6, 8, generator=g)
    inputs = taau.taau_inputs(colour, torch.zeros(1, 2), torch.zeros(1, 2, 6, 8), torch.zeros(1), None, 2, params)
    out, state = taau.blend(inputs, params, taau.Steer(fallback=torch.ones(1, 1, 12, 16)))
    torch.testing.assert_close(out, taau.ycocg_to_rgb(inputs.spatial).clamp(0, 1), atol=1e-6, rtol=0)
    assert torch.equal(state["weight"], torch.zeros_like(state["weight"]))


def test_random_steering_stays_finite_and_in_range():
    model = randomise_convs(build_model(NTAAULRConfig()), noise=2.0)
    state = None
    with torch.no_grad():
        for frame in _frames(4, 19, 33):
            out, _, state = model(frame, state)
            assert torch.isfinite(out).all() and out.min() >= 0.0 and out.max() <= 1.0
            assert (state["weight"] <= model.params.max_weight + 1e-6).all()


# -- the bundle chain ---------------------------------------------------------------------------
LR_SIZES = {"even": (32, 18), "odd": (33, 19)}  # (w, h): the odd one pads the NPU tensors to 34x20
# (w, h) and the config's options of each bundle: a detail branch (model.detail) at the odd size, in
# its first form and in the one finetune --detail fits (finetune.detail.BRANCH)
BUNDLES = {"even": (LR_SIZES["even"], {}), "odd": (LR_SIZES["odd"], {}), "detail": (LR_SIZES["odd"], {"detail": True}),
           "detail_unet": (LR_SIZES["odd"], {"detail": True, "detail_form": "unet", "detail_reads": "all"})}
GOLDEN_FRAMES = 4


@pytest.fixture(scope="module", params=list(BUNDLES))
def bundle(request, tmp_path_factory):
    """A randomly initialised ntaau_lr model (non-zero last layer, :func:`random_ntaau_lr`) exported
    with 4 golden frames from a tiny render at the LR size, and that render."""
    from mnss_kit.cli import main
    from mnss_kit.model import checkpoint

    (w, h), options = BUNDLES[request.param]
    root = tmp_path_factory.mktemp(f"ntaau_lr_{request.param}")
    data = root / "data"
    assert main(["render", "tiny_test", "--out", str(data), "--set", f"frames={GOLDEN_FRAMES}", "--set", "hr_samples=1",
                 "--set", f"lr_size=[{w},{h}]", "--no-progress"]) == 0
    model = random_ntaau_lr(**options)
    assert model.steer.decode[1].weight.abs().max() > 0
    ckpt = checkpoint.save(root / "ntaau_lr.pt", model, {"jitter_pattern": "grid"})
    out = root / "bundle"
    assert main(["export", str(ckpt), "--out", str(out), "--data", str(data), "--resolution", f"{2 * w}x{2 * h}",
                 "--golden-frames", str(GOLDEN_FRAMES), "--no-progress"]) == 0
    return {"bundle": out, "data": data, "lr_size": (w, h), "model": model.eval()}


def test_the_bundle_passes_its_check_and_lists_depth_and_its_state(bundle):
    from mnss_kit.cli import main

    assert main(["bundle", "check", str(bundle["bundle"])]) == 0
    manifest = json.loads((bundle["bundle"] / "manifest.json").read_text())
    assert manifest["model"]["family"] == "ntaau_lr"
    roles = {r["name"]: r["role"] for r in manifest["resources"]}
    assert [n for n, role in roles.items() if role == "input"] == ["color", "depth", "motion"]
    assert roles["prev_depth"] == "state" and manifest["schedule"]["end_of_frame"] == [{"swap": ["depth", "prev_depth"]}]
    w, h = bundle["lr_size"]
    shapes = {t["name"]: t["shape"] for t in manifest["npu"]["tensors"]}
    config = bundle["model"].config
    channels = (8, 6) if not config.detail else (8 + config.scale ** 2, 10)
    assert [shapes[n] for n in manifest["npu"]["inputs"] + manifest["npu"]["outputs"]] == [
        [1, h + h % 2, w + w % 2, channels[0]], [1, h + h % 2, w + w % 2, channels[1]]]
    assert len(manifest["golden"]["frames"]) == GOLDEN_FRAMES


@pytest.mark.parametrize("gpu_backend", ["numpy", "mesa"])
def test_the_emulator_reproduces_the_golden_frames(bundle, gpu_backend):
    """The numpy GPU stage and LiteRT's reference kernels (the golden frames' own) bit for bit over
    every golden frame; the bundle's shaders on Mesa within the golden tolerance on frame 0 (later
    frames read a history that GPU made)."""
    assert_golden_frames(bundle["bundle"], gpu_backend, GOLDEN_FRAMES)


@pytest.mark.parametrize("profile", ["tflite-ref", "tflite-builtin", "xnnpack", "ort-cpu"])
def test_the_numpy_npu_is_bit_exact_to_every_runtime(bundle, profile):
    """The emulator's int8 kernels against the runtime itself (LiteRT's kernel set of the profile,
    or ONNX Runtime), over the render's frames: 0 differing int8 values."""
    differing, compared = npu_differences(bundle["bundle"], bundle["data"], profile, GOLDEN_FRAMES)
    print(f"{profile}: {differing} of {compared} int8 values differ")
    assert compared > 0 and differing == 0


def test_the_bundle_computes_the_model(bundle):
    """The emulated int8 frames against the torch model on the same frames: much closer to it than
    the model is to TAAU, so the bundle carries the steering (trust, fallback, depth state) and not
    just TAAU."""
    from mnss_kit.dataset.format import read_meta
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.emulate.run import sequence_frames

    emulator = Emulator(bundle["bundle"])
    model = bundle["model"]
    without_patch = _without_detail(model) if model.config.detail else None
    seq = next(p for p in sorted(bundle["data"].iterdir()) if p.is_dir() and not p.name.startswith("."))
    state = plain_state = None
    margins, patch_margins = [], []
    for _, frame, _ in sequence_frames(seq, read_meta(seq), GOLDEN_FRAMES, emulator.runner.inputs):
        display = emulator.run_frame(frame).display.astype(np.float32) / 255
        batch = {k: _nchw(frame[k]) for k in ("color", "depth", "motion")}
        batch.update(jitter=torch.from_numpy(np.asarray(frame["jitter"], np.float32))[None],
                     reset=torch.tensor([float(frame["reset"])]))
        with torch.no_grad():
            out, aux, state = model(batch, state)
        to_model, model_to_taau = _mse(hwc(out), display), _mse(hwc(out), hwc(aux["taau"]))
        margins.append(10 * np.log10(model_to_taau / to_model))
        if without_patch is not None:  # the detail patch is drawn as the model draws it
            with torch.no_grad():
                plain, _, plain_state = without_patch(batch, plain_state)
            patch_margins.append(10 * np.log10(_mse(hwc(out), hwc(plain)) / to_model))
    print(f"int8 bundle to the model, closer than the model to TAAU by {np.round(margins, 1)} dB per frame"
          + (f", than to the model without its patch by {np.round(patch_margins, 1)} dB" if patch_margins else ""))
    assert min(margins) > 6 and min(patch_margins, default=np.inf) > 6


def _without_detail(model):
    """A copy of a model with a detail branch whose branch draws nothing (its last conv zero)."""
    import copy

    plain = copy.deepcopy(model)
    with torch.no_grad():
        for p in net.branch_last_conv(plain.steer.detail).parameters():
            p.zero_()
    return plain


def _mse(a: np.ndarray, b: np.ndarray) -> float:
    return float(((a - b) ** 2).mean())


def test_emulate_cli_runs_the_bundle(bundle, tmp_path):
    from mnss_kit.cli import main

    out = tmp_path / "emu"
    assert main(["emulate", str(bundle["bundle"]), "--data", str(bundle["data"]), "--out", str(out), "--frames", "3",
                 "--no-progress"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert all(s["summary"]["frames"] == 3 for s in metrics["sequences"].values())


def test_the_bundle_schedule_hands_the_gpu_the_configs_bounds():
    """The GPU passes get every bound the torch model reads from the config; no filter pass without a filter."""
    from mnss_kit.model.ntaau_lr.gpu_plan import schedule

    npu = {"model": "steer.tflite", "input": "in", "output": "out", "input_q": (0.01, 0), "output_q": (0.02, 3)}
    config = NTAAULRConfig(box_bound=1.5, filter_bound=0.2, trust_depth=0.05, trust_spread_px=2.0)
    steps = {s["pass"]: s["uniforms"] for s in schedule(config, (17, 9), npu, "tflite-ref")["steps"] if s["kind"] == "gpu"}
    assert steps["taau_lr_accumulate_pass"]["u_box_bound"] == {"value": 1.5}
    assert steps["taau_lr_filter_pass"]["u_filter_bound"] == {"value": 0.2}
    assert steps["taau_lr_evidence_pass"]["u_trust_depth"] == {"value": 0.05}
    assert steps["taau_lr_evidence_pass"]["u_trust_spread_px"] == {"value": 2.0}
    plain = schedule(NTAAULRConfig(filter_bound=0.0), (17, 9), npu, "tflite-ref")["steps"]
    assert "taau_lr_filter_pass" not in {s.get("pass") for s in plain}
