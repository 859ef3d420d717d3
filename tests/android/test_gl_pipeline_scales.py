"""The app's GL frame pipeline (android/core on Mesa through JOGL) over ntaau_lr bundles at
fractional scales (issue 44): every tensor the GL side produces matches the golden values, as in
test_gl_pipeline.py.  A small 1.5x bundle (96x54 from 64x36), then the quality modes at 1280x720
output with the shipped quality-mode checkpoint ntaau_lr_modes: 1.5x (LR 853x480) and 1.7x (LR 753x424,
round half up of 752.9 and 423.5)."""

from __future__ import annotations

import json

import pytest
from java_harness import run_gl_pipeline

from mnss_kit.ops.scale import lr_size_for


def _bundle(tmp_path, scale: str, lr_size, hr_size, golden_frames: int, model_scale=None, scale_input: bool = False,
            shipped: str | None = None):
    """A bundle at ``scale`` of a random ntaau_lr net (or of the ``shipped`` checkpoint)."""
    import torch

    from mnss_kit.cli import main
    from mnss_kit.model import checkpoint
    from mnss_kit.model.families import build_model, randomise_convs
    from mnss_kit.model.ntaau_lr.config import NTAAULRConfig

    data = tmp_path / "data"  # calibration at the bundle's scale; golden frames rendered at its LR size when it differs
    assert main(["render", "tiny_test", "--out", str(data), "--scale", scale, "--set", "frames=3", "--set", "hr_samples=1",
                 "--set", f"lr_size=[{lr_size[0]},{lr_size[1]}]", "--set", "jitter=halton", "--no-progress"]) == 0
    torch.manual_seed(0)
    config = NTAAULRConfig(scale=model_scale or float(scale), width=8, mid_layers=1, scale_input=scale_input)
    model = randomise_convs(build_model(config), noise=0.5)
    ckpt = shipped or checkpoint.save(tmp_path / "ntaau_lr.pt", model, {"jitter_pattern": "halton"})
    bundle = tmp_path / "bundle"
    assert main(["export", str(ckpt), "--out", str(bundle), "--resolution", f"{hr_size[0]}x{hr_size[1]}", "--scale", scale,
                 "--data", str(data), "--golden-frames", str(golden_frames), "--no-progress"]) == 0
    manifest = json.loads((bundle / "manifest.json").read_text())
    assert manifest["scale"] == float(scale) and manifest["hr_size"] == list(hr_size)
    assert manifest["lr_size"] == list(lr_size_for(hr_size, float(scale)))
    return bundle, manifest


def test_a_1_5x_bundle_runs_exactly_on_mesa(gl_classes, java_core, tmp_path, capsys):
    bundle, manifest = _bundle(tmp_path, "1.5", (64, 36), (96, 54), 3)
    assert java_core.tool("verify", str(bundle)) == ""
    assert java_core.tool("selftest", str(bundle), str(tmp_path / "dump"), "0").strip().endswith("PASSED")
    tensors, values = run_gl_pipeline(gl_classes, bundle)
    with capsys.disabled():
        print(f"\nGL pipeline at x1.5, 96x54: {tensors} tensors, {values} values compared over 3 golden frames")
    assert tensors == 2 * 3 and values > 0


def test_a_scale_input_bundle_packs_nine_channels_on_mesa(gl_classes, java_core, tmp_path, capsys):
    """An x2 checkpoint with a scale input run at 1.5x: 9 int8 channels per pixel, a word holding
    channels of two pixels."""
    bundle, manifest = _bundle(tmp_path, "1.5", (64, 36), (96, 54), 2, model_scale=2, scale_input=True)
    assert [t["shape"] for t in manifest["npu"]["tensors"] if t["name"] in manifest["npu"]["inputs"]] == [[1, 36, 64, 9]]
    assert java_core.tool("verify", str(bundle)) == ""
    tensors, values = run_gl_pipeline(gl_classes, bundle)
    with capsys.disabled():
        print(f"\nGL pipeline at x1.5 with a scale input: {tensors} tensors, {values} values compared over 2 golden frames")
    assert tensors == 2 * 2 and values > 0


@pytest.mark.slow
@pytest.mark.parametrize("scale, lr_size", [("1.5", (853, 480)), ("1.7", (753, 424))], ids=["1.5", "1.7"])
def test_quality_modes_at_1280x720_run_exactly_on_mesa(gl_classes, tmp_path, capsys, scale, lr_size):
    bundle, manifest = _bundle(tmp_path, scale, (40, 24) if scale == "1.7" else (64, 36), (1280, 720), 2,
                               shipped="ntaau_lr_modes")
    assert manifest["model"]["id"] == "ntaau_lr_modes"
    assert manifest["lr_size"] == list(lr_size)
    tensors, values = run_gl_pipeline(gl_classes, bundle)
    with capsys.disabled():
        print(f"\nGL pipeline at x{scale}, 1280x720 (LR {lr_size[0]}x{lr_size[1]}): {tensors} tensors, {values} values "
              f"compared over 2 golden frames")
    assert tensors == 2 * 2 and values > 0
