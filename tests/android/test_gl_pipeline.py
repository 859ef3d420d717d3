"""The app's GL frame pipeline (android/core's GpuFramePipeline, GlResources, ComputePasses: the
classes the phone runs over android.opengl.GLES31) run here on Mesa llvmpipe through JOGL
(android/gljogl), over an exported bundle's golden frames, the NPU step answered from the golden
files.  Every tensor the GL side produces (the NPU input buffers, the displayed output) must match
the golden values: integer tensors bit-exact, float ones within 1e-3."""

from __future__ import annotations

import json
import re

import pytest
from java_harness import CORE, REPO, run_gl_pipeline

ANDROID_APP = REPO / "android" / "app" / "src" / "main" / "java" / "io" / "mnsskit" / "sample"


def test_app_frame_pipeline_reproduces_the_golden_frames_on_mesa(gl_classes, tiny_bundle, capsys):
    manifest = json.loads((tiny_bundle / "manifest.json").read_text())
    frames = len(manifest["golden"]["frames"])
    tensors, values = run_gl_pipeline(gl_classes, tiny_bundle)
    with capsys.disabled():
        print(f"\nGL pipeline on {manifest['model']['id']}: {tensors} tensors, {values} values compared over {frames} golden frames")
    npu_step = next(s for s in manifest["schedule"]["steps"] if s.get("kind") == "npu")
    assert tensors == frames * (len(npu_step["inputs"]) + 1)  # every NPU input buffer and the output, every frame


def test_app_frame_pipeline_runs_the_shipped_default_model_bit_exact(gl_classes, synthetic_dataset, tmp_path, capsys):
    """The same check on a bundle of the shipped default model (mnss_x2, its trained weights) at 64x48."""
    from mnss_kit.cli import main

    bundle = tmp_path / "mnss_x2"
    assert main(["export", "mnss_x2", "--out", str(bundle), "--resolution", "64x48", "--data", str(synthetic_dataset),
                 "--no-progress"]) == 0
    manifest = json.loads((bundle / "manifest.json").read_text())
    tensors, values = run_gl_pipeline(gl_classes, bundle)
    with capsys.disabled():
        print(f"\nGL pipeline on the shipped {manifest['model']['id']}: {tensors} tensors, {values} values compared "
              f"over {len(manifest['golden']['frames'])} golden frames")
    assert tensors > 0 and values > 0


@pytest.mark.parametrize("detail", [False, True], ids=["plain", "detail"])
def test_app_frame_pipeline_runs_an_ntaau_lr_bundle(gl_classes, java_core, synthetic_dataset, tmp_path, capsys, detail):
    """An ntaau_lr bundle (a random model: an LR depth input that swaps with prev_depth at the end of
    the frame, NPU tensors at the LR size; with a detail branch, 12 NPU input and 10 output channels
    and the patch on the display): the core's verify and self-test, then the GL pipeline over its
    golden frames, every GL-produced tensor within the golden tolerance."""
    from random_ntaau_lr import random_ntaau_lr

    from mnss_kit.cli import main
    from mnss_kit.model import checkpoint

    model = random_ntaau_lr(detail=detail)
    ckpt = checkpoint.save(tmp_path / "ntaau_lr.pt", model, {"jitter_pattern": "grid"})
    bundle = tmp_path / "ntaau_lr"
    assert main(["export", str(ckpt), "--out", str(bundle), "--resolution", "64x48", "--data", str(synthetic_dataset),
                 "--no-progress"]) == 0
    assert java_core.tool("verify", str(bundle)) == ""
    assert java_core.tool("selftest", str(bundle), str(tmp_path / "dump"), "0").strip().endswith("PASSED")
    frames = len(json.loads((bundle / "manifest.json").read_text())["golden"]["frames"])
    tensors, values = run_gl_pipeline(gl_classes, bundle)
    with capsys.disabled():
        print(f"\nGL pipeline on an ntaau_lr bundle{' with a detail branch' if detail else ''}: {tensors} tensors, "
              f"{values} values compared over {frames} golden frames")
    assert tensors == 2 * frames and values > 0  # the NPU input buffer and the display, every frame


def gles31_methods(text: str) -> set[str]:
    return set(re.findall(r"^    [\w\[\]]+ (gl\w+)\(", text, re.M))


def test_phone_binding_forwards_every_call_to_android_gles31():
    """AndroidGles31 cannot be compiled here (no Android SDK): each of its methods must be the one
    line forwarding to the android.opengl.GLES31 call of the same name, and it must cover Gles31."""
    interface = gles31_methods((CORE / "src/main/java/io/mnsskit/core/Gles31.java").read_text())
    phone = (ANDROID_APP / "AndroidGles31.java").read_text()
    forwards = dict(re.findall(r"^    @Override public [\w\[\]]+ (gl\w+)\([^)]*\) \{ (?:return )?(?:\(ByteBuffer\) )?GLES31\.(gl\w+)\(", phone, re.M))
    assert len(interface) > 40 and set(forwards) == interface
    assert all(name == call for name, call in forwards.items())
    assert phone.count("@Override") == len(interface)
