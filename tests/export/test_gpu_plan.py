"""The schedule's workgroup counts cover each pass's grid at a phone size (1280x720 output)."""

from __future__ import annotations

import pytest

from mnss_kit.model.mnss import gpu_plan
from mnss_kit.gpu.passes import PASSES
from mnss_kit.model.mnss.gpu_stage import GpuStage
from mnss_kit.gpu.weights import layers_of
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model

MAX_GROUPS = 65535  # GL ES 3.1 guarantees at least this many workgroups per dimension


@pytest.mark.parametrize("config, lr_size", [("mnss_x2", (640, 360)), ("mnss_x3", (427, 240))])
def test_groups_cover_the_grid(config, lr_size):
    cfg = load_model_config(config)
    stage = GpuStage.from_model(cfg, {k: v.numpy() for k, v in build_model(cfg).state_dict().items()})
    npu = {"model": "npu.tflite", "input": "image", "output": "add", "input_q": (1 / 255, -128), "output_q": (1 / 255, -128)}
    steps = gpu_plan.schedule(stage, lr_size, npu, "tflite-ref")["steps"]
    w, h = lr_size
    s = cfg.scale
    words = -(-w * s * h * s * 3 // 4)
    for step in (x for x in steps if x["kind"] == "gpu"):
        spec = PASSES[step["pass"]]
        groups, local = step["groups"], spec.local_size
        assert max(groups) <= MAX_GROUPS
        covered = [g * l for g, l in zip(groups, local)]
        if spec.grid == "words":
            assert covered[0] * groups[1] >= words and covered[0] * (groups[1] - 1) < words
        else:
            gw, gh = (w * s, h * s) if spec.grid == "hr" else (w, h)
            assert covered[0] >= gw and covered[1] >= gh and covered[0] - local[0] < gw and covered[1] - local[1] < gh
            if spec.grid == "lr_layers":
                assert groups[2] == step["uniforms"]["u_out_layers"]["value"] == layers_of(
                    next(c.out_channels for i, c in enumerate(stage.weights.aa) if step["bind"]["weights"] == f"weights:aa.{i}"))
