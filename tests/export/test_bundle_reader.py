"""Reading a bundle back: the unpacked GPU weights equal the checkpoint's, and the MNSS family's
numpy GPU stage (``model.mnss.gpu_stage``), fed from the bundle alone, reproduces the golden
frames that the schedule interpreter wrote."""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.errors import UserError
from mnss_kit.export.reader import open_bundle, unpack_conv3x3
from mnss_kit.gpu.reference import ReferencePasses
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.mnss.gpu_stage import GpuStage, GpuWeights, NpuBoundary, after_npu, before_npu, next_state
from mnss_kit.gpu.weights import pack_conv3x3
from mnss_kit.model.checkpoint import load


@pytest.mark.parametrize("cout, cin", [(1, 4), (8, 6), (3, 8), (5, 13)])
def test_unpack_inverts_pack(cout, cin):
    rng = np.random.default_rng(cout * 100 + cin)
    w = rng.standard_normal((cout, cin, 3, 3)).astype(np.float32)
    b = rng.standard_normal(cout).astype(np.float32)
    conv = unpack_conv3x3(pack_conv3x3(w, b), cout, cin)
    np.testing.assert_array_equal(conv.weight, w)
    np.testing.assert_array_equal(conv.bias, b)


def _stage(b) -> GpuStage:
    """The MNSS GPU stage from the manifest's config and the bundle's weight blocks."""
    convs = b.gpu_weights()
    aa = tuple(convs[n] for n in sorted((n for n in convs if n.startswith("aa.")), key=lambda n: int(n.split(".")[1])))
    config = MNSSConfig(**b.manifest["model"]["config"])
    return GpuStage(config.scale, config.history == "output", config.inpaint_activation, config.weight_upsample,
                    config.enhance_beta if config.enhance else None, GpuWeights(convs.get("inpaint"), aa))


def _boundary(b) -> NpuBoundary:
    i, o = (next(x for x in b.manifest["boundary"] if x["role"] == r) for r in ("npu_input", "npu_output"))
    return NpuBoundary(i["scale"], i["zero_point"], o["scale"], o["zero_point"], b.manifest["golden"]["profile"])


def test_gpu_weights_come_back_exactly(bundle, tiny_ckpt):
    stage = _stage(open_bundle(bundle))
    state = load(tiny_ckpt)[0].state_dict()
    np.testing.assert_array_equal(stage.weights.inpaint.weight, state["inpaint.conv.weight"].numpy())
    for conv, key in zip(stage.weights.aa, ("aa.net.0", "aa.net.2")):
        np.testing.assert_array_equal(conv.weight, state[key + ".weight"].numpy())
        np.testing.assert_array_equal(conv.bias, state[key + ".bias"].numpy())


def test_reference_pipeline_from_the_bundle_reproduces_golden(bundle):
    from mnss_kit.quantize.runtime import TfliteRunner

    b = open_bundle(bundle)
    stage, boundary = _stage(b), _boundary(b)
    runner = TfliteRunner(b.npu_model(), "tflite-ref")
    passes, state = ReferencePasses(), None
    for i in range(len(b.manifest["golden"]["frames"])):
        frame, want = b.golden_inputs(i), b.golden(i)
        npu_input = before_npu(passes, stage, frame, state, boundary)["npu_input"]
        npu_output = runner.run([npu_input])[b.manifest["npu"]["outputs"][0]]
        history, display = after_npu(passes, stage, npu_output, boundary)
        state = next_state(frame, history)
        np.testing.assert_array_equal(npu_input, want["npu_input"])
        np.testing.assert_array_equal(npu_output, want["npu_output"])
        np.testing.assert_array_equal(display, want["display"])


def test_open_refuses_a_changed_bundle(bundle_copy):
    (bundle_copy / "npu.tflite").write_bytes(b"TFL3")
    with pytest.raises(UserError, match="npu.tflite"):
        open_bundle(bundle_copy)
