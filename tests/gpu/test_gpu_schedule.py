"""A short sequence through the whole GPU stage, shaders on Mesa against the numpy reference.

Both get the same state each frame (the reference's), and an identity "NPU" (its output is
its input) closes the loop, so the frames carry a real history through warp and inpaint."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
from gpu_helpers import assert_float_close, pattern_jitters, random_conv

from mnss_kit.gpu.reference import to_half
from mnss_kit.model.mnss.gpu_stage import GpuStage, NpuBoundary, after_npu, before_npu, next_state
from mnss_kit.model.mnss.gpu_stage import GpuWeights
from mnss_kit.model.mnss.config import aa_input_channels

GPU_PACKAGE = Path(__file__).resolve().parents[2] / "mnss_kit" / "gpu"


def random_stage(rng, scale: int) -> GpuStage:
    state = {}
    for key, (cout, cin, gain) in {"inpaint.conv": (1, 4, 2.0), "aa.net.0": (8, aa_input_channels(True), 0.3), "aa.net.2": (3, 8, 0.3)}.items():
        conv = random_conv(rng, cout, cin, gain)
        state[key + ".weight"], state[key + ".bias"] = conv.weight, conv.bias
    return GpuStage(scale, True, "sigmoid", "bilinear", 0.15, GpuWeights.from_state_dict(state))


def test_sequence_on_mesa_matches_reference(mesa, ref):
    rng = np.random.default_rng(0)
    scale, h, w = 2, 6, 9
    stage = random_stage(rng, scale)
    boundary = NpuBoundary(1 / 255, -128, 1 / 255, -128, "xnnpack")
    jitters = pattern_jitters("grid", scale)
    state = None
    for t in range(4):
        frame = {
            "color": to_half(rng.random((h, w, 3), dtype=np.float32)),
            "depth": rng.random((h, w, 1), dtype=np.float32),
            "motion": (rng.standard_normal((h, w, 2)) * 3).astype(np.float32),
            "jitter": jitters[t],
            "reset": t == 2,
        }
        got, want = before_npu(mesa, stage, frame, state, boundary), before_npu(ref, stage, frame, state, boundary)
        reset = t in (0, 2)  # no state yet, then a cut
        for key in ("warped", "lr_weight"):
            assert (got[key] is None) == (want[key] is None) == reset
        for key in ("warped", "lr_weight", "rectified", "aa"):
            if want[key] is not None:
                assert_float_close(got[key], want[key])
        off = np.abs(got["npu_input"].astype(int) - want["npu_input"])
        assert off.max() <= 1 and off.mean() < 0.01  # a float ulp may tip a byte across a rounding boundary
        npu_output = want["npu_input"]
        (history, display), (want_history, want_display) = (after_npu(p, stage, npu_output, boundary) for p in (mesa, ref))
        np.testing.assert_array_equal(history, want_history)
        assert np.abs(display.astype(int) - want_display).max() <= 1  # sharpen: float sums near a code boundary
        state = next_state(frame, want_history)


def test_gpu_package_does_not_import_torch():
    for path in sorted(GPU_PACKAGE.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            assert not any(n.split(".")[0] == "torch" for n in names), f"{path.name} imports torch"
