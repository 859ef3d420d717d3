"""The FuseSR bundle schedule against the torch model: what the GPU passes pack for the NPU is the
model's backbone input, and what they make of an NPU output is the model's remodulated output
(numpy reference passes; the shaders are held to them in tests/gpu/test_fusesr_passes.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mnss_kit.gpu.interpret import ScheduleRunner
from mnss_kit.gpu.reference import ReferencePasses, encode_unorm8
from mnss_kit.model.families import FAMILIES, build_model, randomise_convs
from mnss_kit.model.family import example_frame
from mnss_kit.model.fusesr.config import FuseSRConfig
from mnss_kit.model.layers import add_upsampled, remodulate
from mnss_kit.ops.int8.quantize import dequantize, quantize

H, W = 6, 8
OUT_Q = (1.0 / 255.0, -128)
CONFIGS = {
    "l_x4": FuseSRConfig(scale=4, variant="l"),
    "hybrid_x2": FuseSRConfig(scale=2, history=True, width=8, hr_channels=4),
    "no_demodulation_some_gbuffers_x3": FuseSRConfig(scale=3, demodulate=False, gbuffers=["depth", "normal"]),
}


def hwc(t: torch.Tensor) -> np.ndarray:
    return np.ascontiguousarray(t[0].permute(1, 2, 0).numpy(), np.float32)


def frames(config, n: int) -> list[dict]:
    out = []
    for t in range(n):
        f = example_frame(FAMILIES["fusesr"], H, W, config.scale, torch.Generator().manual_seed(t))
        f["lr_fbeta"][..., :2, :] = 0.0  # sky rows: nothing divided
        f["hr_fbeta"][..., : 2 * config.scale, :] = 0.0
        f["motion"] = f["motion"] * 0.7
        f["reset"] = torch.tensor([1.0 if t == 0 else 0.0])
        out.append(f)
    return out


@pytest.mark.parametrize("name", CONFIGS)
def test_schedule_packs_and_remodulates_as_the_torch_model(name):
    config = CONFIGS[name]
    model = randomise_convs(build_model(config)).eval()
    packed_inputs = []
    model.backbone.register_forward_pre_hook(lambda module, args: packed_inputs.append(args[0].detach()))
    rng = np.random.default_rng(0)
    npu_output = rng.integers(-128, 128, (1, H * config.scale, W * config.scale, 3)).astype(np.int8)
    input_q = (4.0 / 255.0, -32)  # covers [-1, 3]: normals, features, [0, 1] images
    npu = {"model": "npu.tflite", "input": "x", "output": "y", "input_q": input_q, "output_q": OUT_Q}
    state_dict = {k: v.numpy() for k, v in model.state_dict().items()}
    plan = FAMILIES["fusesr"].gpu_plan(config, state_dict, (W, H), npu, "tflite-ref")
    runner = ScheduleRunner(plan["resources"], plan["schedule"], dict(plan["weights"]), ReferencePasses(),
                            lambda step, feeds: {"y": npu_output}, "tflite-ref", config.scale)
    state = None
    for t, frame in enumerate(frames(config, 3 if config.history else 1)):
        if t > 0:  # the model continues from the history the GPU kept (fp16), as the phone does
            state = {"history": torch.from_numpy(runner.values["history"]).permute(2, 0, 1)[None]}
        with torch.no_grad():
            model(frame, state)
        inputs = {k: hwc(frame[k]) for k in runner.inputs}
        runner.run_frame(inputs, frame["jitter"][0].numpy(), bool(frame["reset"][0] > 0.5))
        want = quantize(hwc(packed_inputs[-1]), *input_q, "int8", "tflite-ref")[None]
        got = runner.values["npu_input"]
        assert got.shape == want.shape
        # fp16 storage of L and of the encoder features moves a code at most one step
        assert np.abs(got.astype(int) - want.astype(int)).max() <= 1, f"frame {t}"
        assert (got != want).mean() < 0.05, f"frame {t}"
        residual = torch.from_numpy(dequantize(npu_output[0], *OUT_Q)).permute(2, 0, 1)[None]
        l = torch.from_numpy(np.asarray(runner.values["l"], np.float32)[..., :3]).permute(2, 0, 1)[None]  # the GPU's L
        prediction = add_upsampled(residual, l, config.scale)
        if config.demodulate:
            prediction = remodulate(prediction, frame["hr_fbeta"], frame["hr_emissive"])
        assert np.abs(runner.values["display"].astype(int) - encode_unorm8(hwc(prediction)).astype(int)).max() <= 1
