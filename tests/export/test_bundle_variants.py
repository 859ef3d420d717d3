"""Model variants change the schedule (enhancement adds sharpen_pass; no history drops warp and the
inpainting conv); each variant's bundle passes its check and its replay matches its golden frames."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from bundle_replay import Replay, read_array

from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.export.check import check_bundle
from mnss_kit.export.run import ExportRequest, export
from mnss_kit.model import checkpoint
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model, randomise_convs

VARIANTS = {
    "enhance_tanh_nearest": dict(enhance=True, inpaint_activation="tanh", weight_upsample="nearest", aa_layers=3),
    "no_history": dict(history="none", aa_layers=1, recon_resolution="hr", recon_layers=2),
    "x3": dict(scale=3),
}


@pytest.mark.parametrize("variant", VARIANTS)
def test_variant_bundle_checks_and_replays(variant, synthetic_dataset, tmp_path):
    from mnss_kit.gpu.mesa import create_context

    torch.manual_seed(1)
    model = build_model(MNSSConfig(**{"scale": 2, "recon_width": 8, "aa_width": 8, **VARIANTS[variant]})).eval()
    randomise_convs(model, prefixes=("",))
    ckpt = checkpoint.save(tmp_path / f"{variant}.pt", model, {"jitter_pattern": "grid"})
    data, size = synthetic_dataset, "64x48"
    if model.scale != 2:
        data, size = tmp_path / "data", f"{16 * model.scale}x{12 * model.scale}"
        write_synthetic_sequence(data / "pan", lr_size=(16, 12), scale=model.scale, frames=3, name="pan")
    out = tmp_path / "bundle"
    export(ExportRequest(model=str(ckpt), out=out, resolution=size, data=data, golden_frames=2, progress=False))
    assert check_bundle(out) == []
    manifest = json.loads((out / "manifest.json").read_text())
    passes = [s.get("pass") for s in manifest["schedule"]["steps"]]
    assert ("sharpen_pass" in passes) == model.config.enhance
    assert ("warp_pass" in passes) == (model.config.history == "output")
    assert passes.count("conv3x3_pass") == model.config.aa_layers
    replay, previous = Replay(create_context(), out), None
    for frame in manifest["golden"]["frames"]:
        got = replay.run_frame(frame, previous)
        previous = frame
        for key in ("npu_input", "npu_output", "display"):
            np.testing.assert_array_equal(got[key], read_array(out, frame["arrays"][key]), err_msg=f"{variant} frame {frame['index']} {key}")
