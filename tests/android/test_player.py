"""The app's playback (android/core's Player: the recorded sequence in a loop through the frame
pipeline, timings, the bilinear upscale beside it, the debug views) run on Mesa llvmpipe through
JOGL (android/gljogl/PlayerCheck), the NPU step answered from the golden files."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from java_harness import run_jogl_main
from mnss_kit.export.sequence import read_sequence_array
from mnss_kit.gpu.reference import encode_unorm8
from mnss_kit.ops.resample import upsample_bilinear

LOOPS = 2


@pytest.fixture(scope="module")
def played(gl_classes, tiny_bundle, tmp_path_factory):
    out = tmp_path_factory.mktemp("player_out")
    run = run_jogl_main(gl_classes, "io.mnsskit.gljogl.PlayerCheck", str(tiny_bundle), str(LOOPS), str(out))
    print(run.stdout)
    if run.returncode != 0:
        pytest.fail(f"PlayerCheck failed:\n{run.stdout[-6000:]}\n{run.stderr[-4000:]}", pytrace=False)
    return run.stdout, out


def test_player_loop_reproduces_the_golden_frames_on_mesa(played, tiny_bundle, capsys):
    """Played as a chain (history, ping-pong and jitter carried from frame to frame, a reset when
    the loop wraps), the frames that are golden frames give the golden NPU input and output bit for bit."""
    stdout, _ = played
    manifest = json.loads((tiny_bundle / "manifest.json").read_text())
    match = re.search(r"^player: (\d+) frames, (\d+) tensors (\d+) values compared, 0 wrong$", stdout, re.M)
    assert match, stdout
    frames, tensors, values = map(int, match.groups())
    npu_step = next(s for s in manifest["schedule"]["steps"] if s.get("kind") == "npu")
    assert frames == LOOPS * manifest["sequence"]["frame_count"]
    assert tensors == LOOPS * len(manifest["golden"]["frames"]) * (len(npu_step["inputs"]) + 1)
    timing = re.search(r"^timing: (.+)$", stdout, re.M).group(1)
    with capsys.disabled():
        print(f"\nplayer on {manifest['model']['id']}: {frames} frames, {tensors} tensors {values} values exact; GPU timed by {timing}")


def test_player_times_every_step(played, tiny_bundle):
    stdout, _ = played
    manifest = json.loads((tiny_bundle / "manifest.json").read_text())
    rows = dict(re.findall(r"^(.+?)\s+([\d.]+) / +[\d.]+ ms", stdout, re.M))
    labels = [s["label"] if s["kind"] == "gpu" else f"NPU {s['label']}" for s in manifest["schedule"]["steps"]]
    assert set(labels) | {"frame"} == {k.strip() for k in rows}
    assert re.search(r"^frame .* ms\s+[\d.]+ FPS$", stdout, re.M)


def test_player_bilinear_is_the_toolkits(played, tiny_bundle):
    """The bilinear panel of the first frame: ops.resample.upsample_bilinear of the recorded LR
    colour at its jitter, encoded as the GPU encodes display values, byte for byte."""
    _, out = played
    manifest = json.loads((tiny_bundle / "manifest.json").read_text())
    colour = read_sequence_array(tiny_bundle, manifest["sequence"]["arrays"]["color"])[0].astype(np.float32)
    jitter = np.float32(manifest["sequence"]["frames"][0]["jitter"])
    expected = encode_unorm8(upsample_bilinear(colour, manifest["scale"], offset=tuple(jitter))[..., :3])
    w, h = manifest["hr_size"]
    actual = np.frombuffer((out / "bilinear.bin").read_bytes(), np.uint8).reshape(h, w, 3)
    np.testing.assert_array_equal(actual, expected)


def view(out, manifest, frame: int, index: int) -> np.ndarray:
    w, h = manifest["hr_size"]
    return np.frombuffer((out / f"view_{frame}_{index}.bin").read_bytes(), np.uint8).reshape(h, w, 3)


def test_player_renders_every_debug_view_of_the_manifest(played, tiny_bundle):
    """Weight map and history mask agree pixel for pixel (marked exactly where the weight's grey
    code is below 128), are white and empty on reset frames (the loop's first frame too), and the
    motion view is the recorded motion coloured by direction and length (colorsys's HSV)."""
    import colorsys

    _, out = played
    manifest = json.loads((tiny_bundle / "manifest.json").read_text())
    views = [v["name"] for v in manifest["debug_views"]]
    assert views == ["weight map", "history taken", "motion"]
    frames = manifest["sequence"]["frames"]
    marked_somewhere = False
    for t in range(LOOPS * len(frames)):
        recorded = frames[t % len(frames)]
        weight, mask, motion = (view(out, manifest, t, i) for i in range(3))
        for image in (weight, mask, motion):  # LR resources, shown nearest: 2x2 per value
            assert (image == np.repeat(np.repeat(image[::2, ::2], 2, 0), 2, 1)).all()
        marked = (mask == (255, 128, 0)).all(-1)
        assert (marked | (mask == 0).all(-1)).all()
        assert (weight[..., 0] == weight[..., 1]).all()
        np.testing.assert_array_equal(marked, weight[..., 0] < 128)
        if recorded["reset"] or t % len(frames) == 0:
            assert (weight == 255).all() and not marked.any(), f"played frame {t} is a reset"
        marked_somewhere |= marked.any()
        if t == 1:
            m = read_sequence_array(tiny_bundle, manifest["sequence"]["arrays"]["motion"])[1].astype(np.float64)
            low, high = manifest["debug_views"][2]["range"]
            expected = np.zeros(m.shape[:2] + (3,), np.uint8)
            for (y, x), (dx, dy) in zip(np.ndindex(m.shape[:2]), m.reshape(-1, 2)):
                length = np.hypot(dx, dy)
                hue = (np.degrees(np.arctan2(dy, dx)) + 360) % 360 / 360 if length else 0.0
                rgb = colorsys.hsv_to_rgb(hue, min(max((length - low) / (high - low), 0), 1), 1)
                expected[y, x] = np.floor(np.asarray(rgb) * 255 + 0.5)
            np.testing.assert_array_equal(motion[::2, ::2], expected)
            assert len(np.unique(expected.reshape(-1, 3), axis=0)) > 1
    assert marked_somewhere, "no pixel took history in any frame: the mask view was never exercised"


def test_player_without_timer_queries_times_around_glfinish(gl_classes, tiny_bundle):
    run = run_jogl_main(gl_classes, "io.mnsskit.gljogl.PlayerCheck", str(tiny_bundle), "1", "", "finish")
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-4000:]
    assert "timing: glFinish + System.nanoTime" in run.stdout
    assert "GPU steps by glFinish + System.nanoTime" in run.stdout
    assert re.search(r"^player: \d+ frames, [1-9]\d* tensors \d+ values compared, 0 wrong$", run.stdout, re.M)
