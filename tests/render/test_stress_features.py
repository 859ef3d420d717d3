"""Switchable stress features: particles add light but no depth, motion or G-buffer; the light animates."""

from __future__ import annotations

import numpy as np

from mnss_kit.render.camera import CameraPath, KeyframeConfig
from mnss_kit.render.config import RenderConfig, SequenceConfig
from mnss_kit.render.renderer import FrameSpec, Renderer
from mnss_kit.render.scenes import build_scene


def render_once(tmp_path, **flags):
    seq = SequenceConfig(name="s", scene="arena", seed=3, frames=30, lr_size=(64, 36), hr_samples=1, **flags)
    scene = build_scene(seq, RenderConfig([seq], source_dir=str(tmp_path)))
    # look at the spark fountain of the first tower from a few metres away
    spark = build_scene(SequenceConfig(name="s", scene="arena", seed=3, particles=True), RenderConfig([seq])).particles(0.2)[0][0, :3]
    scene.camera = CameraPath([KeyframeConfig(0.0, tuple(map(float, spark + (0.0, 1.0, 5.0))), look_at=tuple(map(float, spark)))])
    renderer = Renderer(scene, seq.lr_size, seq.scale, seq.hr_samples)
    try:
        return [renderer.render(FrameSpec(t, t - 1 / 30, (0.25, 0.25))) for t in (0.2, 0.6)]
    finally:
        renderer.release()


def test_particles_change_colour_only_and_light_animates(tmp_path):
    plain = render_once(tmp_path)
    fx = render_once(tmp_path, particles=True)
    lit = render_once(tmp_path, animated_light=True)
    for name in ("depth", "motion", "albedo", "normal", "fbeta"):
        np.testing.assert_array_equal(plain[0]["lr"][name], fx[0]["lr"][name])
        np.testing.assert_array_equal(plain[1]["lr"][name], lit[1]["lr"][name])
    added = fx[0]["lr"]["color"] - plain[0]["lr"]["color"]
    assert added.min() >= 0 and (added.max(-1) > 1e-3).any()  # additive light somewhere on screen
    # the emissive buffer is half float (relative step 2^-10): compare within its precision
    emissive = fx[0]["lr"]["emissive"]
    assert np.all(np.abs(added - (emissive - plain[0]["lr"]["emissive"])) <= 1e-3 + 2e-3 * np.abs(emissive))
    shading_change = np.abs(lit[1]["lr"]["color"] - plain[1]["lr"]["color"]).mean()
    assert shading_change > 1e-3  # the sun moved and dimmed: shading changes the motion vectors do not explain
