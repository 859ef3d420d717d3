"""The numpy reference of the whole GPU stage against the PyTorch model's GPU-side modules
(warp, inpaint, aa, insert, enhance) on the tiny x2 config with randomised weights.

The reference stores what the GPU stores in fp16 (I_W, I_R, the AA net's activations) and
the model keeps float32, so they differ by fp16 rounding.  Stated tolerances (values in
[0, 1], where an fp16 step is at most 2^-11 ~ 4.9e-4):
    I_W        5e-4   one rounding of the warped history
    I_R        1e-3   the rounded I_W and LR weights carried through the blend, then rounded
    I_AA       2e-3   fp16 input and ReLU activations through the conv stack
    NPU input  1 LSB  bytes of quantize(I_R with I_AA inserted), at most 10% of them off by one
    display    1 code the unsharp enhancement encoded to 8 bits
"""

from __future__ import annotations

import numpy as np
import pytest
import torch
from gpu_helpers import pattern_jitters

from mnss_kit.gpu.reference import ReferencePasses, encode_unorm8, to_half
from mnss_kit.model.mnss.gpu_stage import GpuStage, NpuBoundary, after_npu, before_npu
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model
from mnss_kit.ops.int8 import quantize as quant

TOLERANCE = {"warped": 5e-4, "rectified": 1e-3, "aa": 2e-3}
BOUNDARY = NpuBoundary(1 / 255, -128, 1 / 255, -128, "tflite-ref")
H, W = 8, 10


def tiny_model(*overrides: str):
    """mnss_x2_tiny with every weight moved off its initial value (the AA net's last conv starts at zero)."""
    config = load_model_config("mnss_x2_tiny", overrides=list(overrides))
    torch.manual_seed(0)
    model = build_model(config).eval()
    g = torch.Generator().manual_seed(1)
    with torch.no_grad():
        for p in model.parameters():
            p.add_(torch.randn(p.shape, generator=g) * 0.2)
    state_dict = {k: v.numpy() for k, v in model.state_dict().items()}
    return model, GpuStage.from_model(config, state_dict)


def nchw(a: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(np.moveaxis(a, -1, 0)))[None]


def hwc(t: torch.Tensor) -> np.ndarray:
    return t[0].permute(1, 2, 0).numpy()


def inputs(scale: int, t: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    jitters = pattern_jitters("grid", scale)
    frame = {
        "color": to_half(rng.random((H, W, 3), dtype=np.float32)),
        "depth": rng.random((H, W, 1), dtype=np.float32),
        "motion": (rng.standard_normal((H, W, 2)) * 2).astype(np.float32),
        "jitter": jitters[t % len(jitters)],
        "reset": False,
    }
    state = {
        "history": to_half(rng.random((H * scale, W * scale, 3), dtype=np.float32)),
        "depth": rng.random((H, W, 1), dtype=np.float32),
        "jitter": jitters[(t - 1) % len(jitters)],
    }
    return frame, state


def model_gpu_side(model, frame, state, reset: bool) -> dict:
    """The model's GPU modules on one frame, as MNSS.forward chains them."""
    jitter, prev_jitter = torch.from_numpy(frame["jitter"])[None], torch.from_numpy(state["jitter"])[None]
    color, depth = nchw(frame["color"]), nchw(frame["depth"])
    cut = torch.full((1, 1, 1, 1), reset)
    with torch.no_grad():
        warped, warped_depth = model.warp(nchw(state["history"]), nchw(state["depth"]), prev_jitter, nchw(frame["motion"]))
        rectified, _, _ = model.inpaint(color, depth, jitter, warped, warped_depth, cut)
        aa = model.aa(rectified, color, jitter)
        inserted = model.insert(rectified, aa, jitter)
    return {"warped": hwc(warped), "rectified": hwc(rectified), "aa": hwc(aa), "inserted": hwc(inserted)}


@pytest.mark.parametrize(
    "overrides",
    [(), ("model.inpaint_activation=tanh", "model.weight_upsample=nearest"), ("model.scale=3",),
     ("model.aa_history_at_samples=false",), ("model.scale=3", "model.aa_history_at_samples=false")],
    ids=["x2", "x2-tanh-nearest", "x3", "x2-paper-aa-input", "x3-paper-aa-input"],
)
@pytest.mark.parametrize("reset", [False, True], ids=["history", "reset"])
def test_reference_gpu_stage_matches_model(overrides, reset):
    model, stage = tiny_model(*overrides)
    for t in range(3):
        frame, state = inputs(stage.scale, t, seed=t)
        frame["reset"] = reset
        got = before_npu(ReferencePasses(), stage, frame, state, BOUNDARY)
        want = model_gpu_side(model, frame, state, reset)
        for key, atol in TOLERANCE.items():
            if got.get(key) is None:
                assert reset and key == "warped"
                continue
            err = np.abs(got[key] - want[key]).max()
            assert err <= atol, f"{key}: max error {err:.3g} > {atol}"
        q = quant.quantize(want["inserted"], BOUNDARY.input_scale, BOUNDARY.input_zero_point, "int8", BOUNDARY.profile)[None]
        off = np.abs(got["npu_input"].astype(int) - q)
        assert off.max() <= 1 and off.mean() <= 0.1


def test_history_reset_and_enhancement_match_model():
    """A reset ignores the history (I_R = I_U, whatever the history holds); the displayed
    enhancement is the model's unsharp on the dequantized output, within one 8-bit code."""
    model, stage = tiny_model("model.enhance=true")
    frame, state = inputs(2, 0)
    frame["reset"] = True
    poisoned = dict(state, history=np.full_like(state["history"], np.nan))
    got = before_npu(ReferencePasses(), stage, frame, poisoned, BOUNDARY)
    want = model_gpu_side(model, frame, state, reset=True)
    assert np.abs(got["rectified"] - want["rectified"]).max() <= TOLERANCE["rectified"]
    npu_output = got["npu_input"]  # stands in for the NPU's answer
    history, display = after_npu(ReferencePasses(), stage, npu_output, BOUNDARY)
    dequantized = quant.dequantize(npu_output[0], BOUNDARY.output_scale, BOUNDARY.output_zero_point)
    np.testing.assert_array_equal(history, to_half(dequantized))
    with torch.no_grad():
        enhanced = hwc(model.enhance(nchw(dequantized)))
    assert np.abs(display.astype(int) - encode_unorm8(enhanced)).max() <= 1


@pytest.mark.parametrize("reset", [False, True], ids=["history", "reset"])
def test_reference_gpu_stage_matches_model_on_a_bad_frame(reset):
    """NaN colour texels (whole, and in one channel) are no samples, in the model and the GPU stage
    alike: inpainting weight 0 (I_R is the warped history there), no I_AA inserted; every value
    finite and within the stated tolerances (I_AA where a sample was inserted)."""
    from mnss_kit.model.taau import colour_not_finite, sanitize_colour
    from mnss_kit.ops.sanitize import NO_SAMPLE

    model, stage = tiny_model()
    frame, state = inputs(stage.scale, 1, seed=5)
    frame["reset"] = reset
    frame["color"][2:4, 3:6] = np.nan
    frame["color"][6, 1, 2] = np.nan
    got = before_npu(ReferencePasses(), stage, frame, state, BOUNDARY)
    raw = nchw(frame["color"])
    invalid = colour_not_finite(raw)
    jitter, prev_jitter = torch.from_numpy(frame["jitter"])[None], torch.from_numpy(state["jitter"])[None]
    color, depth = sanitize_colour(raw), nchw(frame["depth"])
    with torch.no_grad():
        warped, warped_depth = model.warp(nchw(state["history"]), nchw(state["depth"]), prev_jitter, nchw(frame["motion"]))
        rectified, weight, _ = model.inpaint(color, depth, jitter, warped, warped_depth, torch.full((1, 1, 1, 1), reset),
                                             invalid)
        aa = model.aa(rectified, color, jitter)
        inserted = model.insert(rectified, aa, jitter, invalid)
    bad = hwc(invalid)[..., 0]
    assert not reset or float(weight.min()) == 1.0
    if not reset:
        assert np.all(got["lr_weight"][bad] == 0)
        assert np.abs(got["warped"] - hwc(warped)).max() <= TOLERANCE["warped"]
    assert np.abs(got["rectified"] - hwc(rectified)).max() <= TOLERANCE["rectified"]
    assert np.all(got["aa"][bad] == NO_SAMPLE)
    assert np.abs(got["aa"][~bad] - hwc(aa)[~bad]).max() <= TOLERANCE["aa"]
    q = quant.quantize(hwc(inserted), BOUNDARY.input_scale, BOUNDARY.input_zero_point, "int8", BOUNDARY.profile)[None]
    off = np.abs(got["npu_input"].astype(int) - q)
    assert off.max() <= 1 and off.mean() <= 0.1
