"""ntaau_lr at any scale (issue 44): TAAU maps HR pixel X to LR by the exact per-axis ratio, the
integer paths stay as they were, the torch model matches its numpy references at 1.5x and 1.7x,
and a randomly initialised model goes through the bundle chain at fractional scales: export
``--scale``, bundle check, the emulator bit-exact to its golden frames and to every runtime."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from mnss_kit.errors import UserError
from mnss_kit.model import taau
from mnss_kit.model.families import FAMILIES, build_model, randomise_convs
from mnss_kit.model.family import check_data_scale, example_frame
from mnss_kit.model.ntaau_lr import net
from mnss_kit.model.ntaau_lr.config import NTAAULRConfig
from mnss_kit.ops import taau as ops_taau
from mnss_kit.ops import taau_lr
from ntaau_lr_checks import assert_close, assert_golden_frames, gather_against_reference, hwc, npu_differences
from mnss_kit.ops.scale import INTEGER_SCALE_ONLY, lr_size_for


ATOL = 1e-4  # torch and numpy, float32 against float64 Gaussian weights at a ratio that is no power of two



def _close(got: torch.Tensor, want: np.ndarray, atol: float = ATOL) -> None:
    assert_close(got, want, atol)


# -- the mapping ----------------------------------------------------------------------------------
def test_nearest_index_is_the_tile_at_integer_scales_and_the_ratio_otherwise():
    for s in (2, 3, 4):
        assert torch.equal(taau.nearest_index(7 * s, 7), torch.arange(7 * s) // s)
    # 96 -> 64 at 1.5: HR pixel X reads LR floor((X + 0.5) * 64 / 96)
    assert taau.nearest_index(96, 64)[:6].tolist() == [0, 1, 1, 2, 3, 3]  # 0.33, 1.0, 1.67, 2.33, 3.0, 3.67
    assert np.array_equal(ops_taau.nearest_index(1280, 753), taau.nearest_index(1280, 753).numpy())
    x = torch.rand(1, 2, 5, 7)
    assert torch.equal(taau.nearest_up(x, 3), x.repeat_interleave(3, 2).repeat_interleave(3, 3))


@pytest.mark.parametrize("scale", [2, 3])
def test_the_general_block_mean_is_avg_pool_at_integer_scales(scale):
    x = torch.rand(1, 3, 6 * scale, 5 * scale)
    general = taau.block_mean(x, (6, 5), scale)
    assert torch.equal(general, torch.nn.functional.avg_pool2d(x, scale))
    # the ratio path on the same tiles: the same means within float rounding
    n, c, hh, ww = x.shape
    rows, cols = taau.nearest_index(hh, 6), taau.nearest_index(ww, 5)
    assert torch.equal(rows, torch.arange(hh) // scale) and torch.equal(cols, torch.arange(ww) // scale)


def test_block_means_cover_each_hr_pixel_once_at_1_5():
    x = torch.rand(1, 1, 54, 96, dtype=torch.float64)
    means = taau.block_mean(x, (36, 64), 1.5)
    counts = torch.bincount(taau.nearest_index(54, 36)).view(-1, 1) * torch.bincount(taau.nearest_index(96, 64)).view(1, -1)
    assert set(counts.unique().tolist()) <= {1, 2, 4} and int(counts.sum()) == 54 * 96
    torch.testing.assert_close((means[0, 0] * counts).sum(), x.sum())
    np.testing.assert_allclose(taau_lr.block_mean(hwc(x.float()), (36, 64), 1.5), hwc(means.float()), atol=1e-6)


# -- torch against numpy at fractional scales -----------------------------------------------------
@pytest.mark.parametrize("scale, lr, hr", [(1.5, (36, 64), (96, 54)), (1.7, (24, 40), (68, 41)), (1.7, (53, 94), (160, 90))],
                         ids=["1.5", "1.7", "1.7-display-size"])
def test_taau_terms_match_the_numpy_reference(scale, lr, hr):
    g = torch.Generator().manual_seed(1)
    colour, jitter = torch.rand(1, 3, *lr, generator=g), torch.rand(1, 2, generator=g) - 0.5
    motion = torch.randn(1, 2, *lr, generator=g)
    state = {"history": torch.rand(1, 3, hr[1], hr[0], generator=g), "weight": 9 * torch.rand(1, 1, hr[1], hr[0], generator=g)}
    params = taau.TAAUParams()
    inputs = taau.taau_inputs(colour, jitter, motion, torch.zeros(1), state, scale, params)
    assert inputs.samples.shape[-2:] == (hr[1], hr[0])
    want = ops_taau.current_terms(hwc(colour), jitter[0].numpy(), scale, params.sample_sigma, hr)
    for name, w in zip(("samples", "sample_weight", "spatial", "lo", "hi"), want):
        _close(getattr(inputs, name), w)
    colour_h, weight_h = ops_taau.reprojected_history(hwc(state["history"]), hwc(state["weight"]), hwc(motion), False, scale)
    _close(inputs.history, colour_h)
    np.testing.assert_allclose(hwc(inputs.history_weight), weight_h, atol=2e-4, rtol=1e-4)  # weights up to 9
    # the HR motion is scaled per axis by the exact ratio: a uniform LR motion of 1 pixel
    hr_motion = taau.hr_motion_of(torch.ones(1, 2, *lr), scale, hr)
    torch.testing.assert_close(hr_motion[0, :, 0, 0], torch.tensor([hr[0] / lr[1], hr[1] / lr[0]]))


@pytest.mark.parametrize("scale, lr", [(1.5, (18, 32)), (1.7, (19, 33))], ids=["1.5", "1.7"])
def test_the_gather_and_the_steering_match_the_numpy_reference(scale, lr):
    config = NTAAULRConfig(scale=scale, box_bound=1.5, filter_bound=0.2)
    model = build_model(config)
    g = torch.Generator().manual_seed(2)
    gathered = gather_against_reference(model, *(example_frame(FAMILIES["ntaau_lr"], *lr, 2, generator=g) for _ in range(2)))
    _close(gathered.features, gathered.want)
    raw = 3.0 * torch.randn(1, 6, *lr, generator=g)
    hr_size = (gathered.inputs.samples.shape[-1], gathered.inputs.samples.shape[-2])
    steer = net.steer_from_lr(raw, gathered.trust_lr, config, hr_size)
    want_steer = taau_lr.steer_from_lr(hwc(raw), hwc(gathered.trust_lr), scale, config.box_bound, config.filter_bound, hr_size)
    for name in ("history_gain", "sample_gain", "box_widen", "fallback", "filter_axis", "filter_diagonal"):
        _close(getattr(steer, name), getattr(want_steer, name))


def test_a_fresh_model_at_1_7_is_taau_at_1_7():
    from mnss_kit.eval.baselines import TAAU

    model, baseline = build_model(NTAAULRConfig(scale=1.7)), TAAU(1.7)
    state = ref_state = None
    g = torch.Generator().manual_seed(4)
    with torch.no_grad():
        for _ in range(3):
            frame = example_frame(FAMILIES["ntaau_lr"], 20, 30, 2, generator=g)
            out, aux, state = model(frame, state)
            ref, _, ref_state = baseline(frame, ref_state)
            assert out.shape == (1, 3, 34, 51) and torch.equal(out, ref) and torch.equal(aux["taau"], ref)


def test_scale_input_adds_the_reciprocal_scale_and_the_frame_scale_sets_the_size():
    torch.manual_seed(0)
    model = randomise_convs(build_model(NTAAULRConfig(scale=2, width=8, mid_layers=1, scale_input=True)), noise=0.5).eval()
    assert model.config.npu_input_channels() == 9 and model.takes_frame_scale
    for s, hw, hr in ((1.5, (18, 32), (27, 48)), (1.7, (20, 30), (34, 51)), (2.0, (9, 13), (18, 26))):
        frame = example_frame(FAMILIES["ntaau_lr"], *hw, 2, generator=torch.Generator().manual_seed(0))
        frame["scale"] = torch.tensor([s], dtype=torch.float32)
        seen = []
        hook = model.steer.register_forward_pre_hook(lambda m, args: seen.append(args[0]))
        with torch.no_grad():
            out, _, state = model(frame)
        hook.remove()
        assert out.shape[-2:] == hr and torch.allclose(seen[0][:, 8], torch.tensor(1.0 / s))


def test_config_scales():
    assert NTAAULRConfig(scale=2.0).scale == 2 and isinstance(NTAAULRConfig(scale=2.0).scale, int)
    assert NTAAULRConfig(scale=1.7).scale == 1.7 and NTAAULRConfig().npu_input_channels() == 8
    for bad in (1.0, 0.5, 9, float("nan"), 1.23456):
        with pytest.raises(ValueError):
            NTAAULRConfig(scale=bad)
    assert "ntaau_lr" not in INTEGER_SCALE_ONLY
    check_data_scale("ntaau_lr", 1.5, 1.5)
    for family in ("mnss", "fusesr", "ntaau"):
        with pytest.raises(UserError, match="takes integer scales only"):
            check_data_scale(family, 2, 1.5)


def test_the_models_listing_says_which_families_take_fractional_scales(capsys):
    from mnss_kit.cli import main

    assert main(["models"]) == 0
    out = capsys.readouterr().out
    assert "ntaau_lr" in out and "fractional" in out


# -- the bundle chain at 1.5x and 1.7x ------------------------------------------------------------
GOLDEN_FRAMES = 4
CHAINS = {"1.5": ("1.5", (64, 36), (96, 54)), "1.7": ("1.7", (40, 24), (68, 41))}


@pytest.fixture(scope="module", params=list(CHAINS))
def bundle(request, tmp_path_factory):
    """A randomly initialised ntaau_lr model at the scale, exported with 4 golden frames from a tiny
    render at the bundle's LR size (Halton jitter: grid exists at integer scales only)."""
    from mnss_kit.cli import main
    from mnss_kit.model import checkpoint

    s, (w, h), (hw, hh) = CHAINS[request.param]
    assert tuple(lr_size_for((hw, hh), float(s))) == (w, h)
    root = tmp_path_factory.mktemp(f"ntaau_lr_x{s}")
    data = root / "data"
    assert main(["render", "tiny_test", "--out", str(data), "--scale", s, "--set", f"frames={GOLDEN_FRAMES}",
                 "--set", "hr_samples=1", "--set", f"lr_size=[{w},{h}]", "--set", "jitter=halton", "--no-progress"]) == 0
    torch.manual_seed(0)
    model = randomise_convs(build_model(NTAAULRConfig(scale=float(s), width=8, mid_layers=1)), noise=0.5)
    ckpt = checkpoint.save(root / "ntaau_lr.pt", model, {"jitter_pattern": "halton"})
    out = root / "bundle"
    assert main(["export", str(ckpt), "--out", str(out), "--data", str(data), "--resolution", f"{hw}x{hh}", "--scale", s,
                 "--golden-frames", str(GOLDEN_FRAMES), "--no-progress"]) == 0
    return {"bundle": out, "data": data, "lr_size": (w, h), "hr_size": (hw, hh), "scale": float(s)}


def test_the_bundle_records_its_sizes_and_passes_its_check(bundle):
    from mnss_kit.cli import main

    assert main(["bundle", "check", str(bundle["bundle"])]) == 0
    manifest = json.loads((bundle["bundle"] / "manifest.json").read_text())
    assert manifest["scale"] == bundle["scale"] and manifest["model"]["config"]["scale"] == bundle["scale"]
    assert tuple(manifest["lr_size"]) == bundle["lr_size"] and tuple(manifest["hr_size"]) == bundle["hr_size"]
    passes = [s["pass"] for s in manifest["schedule"]["steps"] if s["kind"] == "gpu"]
    assert passes[0] == "taau_lr_reproject_pass" and "taau_reproject_pass" not in passes
    assert all(s["uniforms"].get("u_scale", {"value": 0})["value"] == 0 for s in manifest["schedule"]["steps"] if s["kind"] == "gpu")
    sizes = {r["name"]: r["size"] for r in manifest["resources"] if r["kind"] == "texture2d"}
    assert sizes["history"] == list(bundle["hr_size"]) and sizes["color"] == list(bundle["lr_size"])


@pytest.mark.parametrize("gpu_backend", ["numpy", "mesa"])
def test_the_emulator_reproduces_the_golden_frames(bundle, gpu_backend):
    """numpy GPU stage: bit for bit over every golden frame; the bundle's shaders on Mesa: frame 0
    within the golden tolerance (later frames read a history that GPU made)."""
    assert_golden_frames(bundle["bundle"], gpu_backend, GOLDEN_FRAMES)


@pytest.mark.parametrize("profile", ["tflite-ref", "tflite-builtin", "xnnpack", "ort-cpu"])
def test_the_numpy_npu_is_bit_exact_to_every_runtime(bundle, profile):
    differing, compared = npu_differences(bundle["bundle"], bundle["data"], profile, GOLDEN_FRAMES)
    print(f"x{bundle['scale']:g} {profile}: {differing} of {compared} int8 values differ")
    assert compared > 0 and differing == 0


def test_emulate_takes_the_bundles_scale_and_refuses_others(bundle, tmp_path, capsys):
    from mnss_kit.cli import main

    out = tmp_path / "emu"
    s = f"{bundle['scale']:g}"
    assert main(["emulate", str(bundle["bundle"]), "--data", str(bundle["data"]), "--out", str(out), "--frames", "2",
                 "--scale", s, "--no-progress"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert all(seq["summary"]["frames"] == 2 for seq in metrics["sequences"].values())
    capsys.readouterr()
    assert main(["emulate", str(bundle["bundle"]), "--data", str(bundle["data"]), "--out", str(tmp_path / "e2"),
                 "--scale", "2", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert f"the bundle is x{s}, not --scale 2" in err and "\n" not in err


@pytest.mark.parametrize("command", ["emulate", "bench"])
@pytest.mark.parametrize("value, message", [("0.5", "--scale 0.5 is outside"), ("1.0", "--scale 1 is outside"),
                                            ("nan", "finite"), ("9", "--scale 9 is outside")])
def test_bad_scales_are_refused_in_one_line(command, value, message, tmp_path, capsys):
    from mnss_kit.cli import main

    args = {"emulate": ["emulate", str(tmp_path / "b"), "--data", str(tmp_path), "--out", str(tmp_path / "o")],
            "bench": ["bench", "--out", str(tmp_path / "bench.json"), "--work", str(tmp_path / "w")]}[command]
    assert main([*args, "--scale", value]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and "Traceback" not in err


def test_export_refuses_bad_scales_and_other_scales_for_integer_families(capsys, tmp_path):
    from mnss_kit.cli import main

    assert main(["export", "mnss_x2", "--out", str(tmp_path / "b"), "--scale", "0.5"]) == 2
    assert "--scale 0.5 is outside" in capsys.readouterr().err
    assert main(["export", "mnss_x2", "--out", str(tmp_path / "b"), "--scale", "1.5", "--resolution", "96x54"]) == 2
    err = capsys.readouterr().err.strip()
    assert "the mnss family runs at the scale it was built for only" in err and "\n" not in err


# -- one checkpoint, several scales ---------------------------------------------------------------
@pytest.fixture(scope="module")
def scale_input_bundles(tmp_path_factory):
    """One x2 checkpoint with ``scale_input`` (9 NPU input channels, the 9th 1/s) exported at 1.5x
    and 1.7x, each with data rendered at its scale."""
    from mnss_kit.cli import main
    from mnss_kit.model import checkpoint

    root = tmp_path_factory.mktemp("ntaau_lr_scale_input")
    torch.manual_seed(0)
    model = randomise_convs(build_model(NTAAULRConfig(scale=2, width=8, mid_layers=1, scale_input=True)), noise=0.5)
    ckpt = checkpoint.save(root / "ntaau_lr_si.pt", model, {"jitter_pattern": "halton"})
    out = {}
    for s, (_, (w, h), (hw, hh)) in CHAINS.items():
        data = root / f"data{s}"
        assert main(["render", "tiny_test", "--out", str(data), "--scale", s, "--set", "frames=3", "--set", "hr_samples=1",
                     "--set", f"lr_size=[{w},{h}]", "--set", "jitter=halton", "--no-progress"]) == 0
        bundle = root / f"bundle{s}"
        assert main(["export", str(ckpt), "--out", str(bundle), "--data", str(data), "--resolution", f"{hw}x{hh}",
                     "--scale", s, "--golden-frames", "3", "--no-progress"]) == 0
        out[s] = {"bundle": bundle, "data": data, "lr_size": (w, h), "scale": float(s)}
    return ckpt, out


def test_one_scale_input_checkpoint_exports_at_several_scales(scale_input_bundles):
    """The 9-channel pack: the numpy GPU stage bit-exact to the golden frames, the bundle's shaders on
    Mesa within the golden tolerance on frame 0; the 9th channel is 1/s of each bundle; the int8
    bundle close to the torch model run at that scale (frame key ``scale``)."""
    from mnss_kit.cli import main
    from mnss_kit.dataset.format import read_meta
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.emulate.run import sequence_frames
    from mnss_kit.export.golden import TOLERANCES
    from mnss_kit.export.reader import open_bundle
    from mnss_kit.model import checkpoint
    from mnss_kit.ops.int8 import quantize as quant

    ckpt, bundles = scale_input_bundles
    for s, b in bundles.items():
        assert main(["bundle", "check", str(b["bundle"])]) == 0
        reader = open_bundle(b["bundle"])
        w, h = b["lr_size"]
        for backend in ("numpy", "mesa"):
            emulator = Emulator(b["bundle"], gpu_backend=backend)
            for i in range(3 if backend == "numpy" else 1):
                want, result = reader.golden(i), emulator.run_frame(reader.golden_inputs(i), keep_all=True)
                got = result.tensors["npu_input"]
                assert got.shape == (1, h + h % 2, w + w % 2, 9)
                if backend == "mesa":
                    assert np.abs(got.astype(int) - want["npu_input"].astype(int)).max() <= TOLERANCES["npu_input_lsb"]
                    continue
                assert np.array_equal(got, want["npu_input"]) and np.array_equal(result.display, want["display"])
        boundary = next(x for x in reader.manifest["boundary"] if x["direction"] == "gpu->npu")
        ninth = quant.dequantize(reader.golden(1)["npu_input"][..., 8], boundary["scale"], boundary["zero_point"])
        np.testing.assert_allclose(ninth, 1.0 / b["scale"], atol=boundary["scale"])
        model, _ = checkpoint.load(ckpt)
        model.eval()
        emulator = Emulator(b["bundle"])
        seq = next(p for p in sorted(b["data"].iterdir()) if p.is_dir() and not p.name.startswith("."))
        state, margins = None, []
        for _, frame, _ in sequence_frames(seq, read_meta(seq), 3, emulator.runner.inputs):
            display = emulator.run_frame(frame).display.astype(np.float32) / 255
            batch = {k: torch.from_numpy(np.ascontiguousarray(np.moveaxis(frame[k], -1, 0)))[None] for k in ("color", "depth", "motion")}
            batch.update(jitter=torch.from_numpy(np.asarray(frame["jitter"], np.float32))[None],
                         reset=torch.tensor([float(frame["reset"])]), scale=torch.tensor([b["scale"]]))
            with torch.no_grad():
                out, aux, state = model(batch, state)
            mse = lambda a, c: float(((a - c) ** 2).mean())  # noqa: E731
            margins.append(10 * np.log10(mse(hwc(out), hwc(aux["taau"])) / mse(hwc(out), display)))
        print(f"x{s}: int8 bundle closer to the model than the model to TAAU by {np.round(margins, 1)} dB")
        assert min(margins) > 6
