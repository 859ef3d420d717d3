"""The garden and the plaza: alpha-tested cut-outs leave holes, articulated limbs get exact motion
vectors, both scenes render deterministically and pass data check, no training config renders the
garden and only training configs render the plaza."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from mnss_kit.config import CONFIG_DIR
from mnss_kit.dataset.check import check_dataset
from mnss_kit.dataset.exr import read_exr
from mnss_kit.render import shapes, textures
from mnss_kit.render.camera import CameraPath, KeyframeConfig
from mnss_kit.render.config import load_render_config
from mnss_kit.render.mesh import Material
from mnss_kit.render.renderer import FrameSpec, Renderer
from mnss_kit.render.scene import Instance, Scene
from mnss_kit.render.scenes import figures
from mnss_kit.render.run import render_dataset

LR = (64, 36)
CAMERA_Z, WALL_Z, FOV = 2.0, -5.0, 60.0

TINY = """
version: 1
defaults: {lr_size: [64, 36], scale: 2, jitter: grid, hr_samples: 4, fps: 30, frames: 5}
sequences:
  - {name: garden, scene: garden, seed: 401, particles: true, animated_light: true, start_time: 0.3}
  - {name: plaza, scene: plaza, seed: 21, particles: true, frames: 3}
"""


def render_frame(meshes, instances, t: float = 0.5) -> dict:
    """HR buffers (one sample at pixel centres) of ``meshes`` seen from z = CAMERA_Z looking down -z."""
    camera = CameraPath([KeyframeConfig(0.0, (0.0, 0.0, CAMERA_Z), look_at=(0.0, 0.0, 0.0))], FOV)
    scene = Scene("test", meshes, instances, camera, near=0.1, far=50.0, shadow_radius=10.0)
    renderer = Renderer(scene, LR, 2, hr_samples=1)
    try:
        out = renderer.render(FrameSpec(t, t - 1 / 30, (0.25, -0.25)))
        return {**out["hr"], "view_proj": renderer.camera(t).proj @ renderer.camera(t).view}
    finally:
        renderer.release()


def wall() -> tuple:
    mesh = shapes.box((40.0, 30.0, 0.2), Material(base_color_texture=textures.bricks(np.random.default_rng(0))), 2.0)
    return mesh, shapes.translate(0, 0, WALL_Z)


def pixel_centres(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """NDC x and y (up) of every pixel centre, ``(h, w)`` each."""
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    return xs / w * 2 - 1, 1 - ys / h * 2


def test_alpha_cut_leaves_holes_where_the_texture_is_transparent():
    texture = textures.pickets(np.random.default_rng(1))
    card = Material(base_color_texture=texture, alpha_mode="mask", double_sided=True)
    width, height = 6.0, 4.0  # larger than the view at the camera distance
    brick, at = wall()
    hr = render_frame([shapes.quad(width, height, card), brick], [Instance(0, shapes.translate(0, -height / 2, 0)), Instance(1, at)])
    depth = hr["depth"][..., 0]
    h, w = depth.shape
    # the card faces the camera: screen position maps linearly to the card's uv
    half_h = CAMERA_Z * math.tan(math.radians(FOV / 2))
    nx, ny = pixel_centres(h, w)
    u = (nx * half_h * w / h + width / 2) / width
    v = 1 - (ny * half_h + height / 2) / height
    size = texture.shape[0]
    transparent = texture[(v * size).astype(int), (u * size).astype(int), 3] < 128
    behind = depth > np.median(depth[~transparent])  # farther than the card: the wall shows through
    assert 0.2 < transparent.mean() < 0.8
    assert (behind == transparent).mean() > 0.97  # all but texel edges (mip filtering of the alpha)
    wall_depth = np.median(depth[transparent])
    assert np.allclose(depth[behind & transparent], wall_depth, atol=1e-3)  # the wall itself, not the card


def test_limb_motion_vectors_follow_each_limbs_transform():
    outfit = figures.Outfit(Material(base_color=(0.8, 0.2, 0.2)), Material(base_color=(0.2, 0.2, 0.8)), Material())

    def path(t: float):  # runs across the view along x, 3.5 m from the camera
        return np.array([-1.0 + 3.0 * t, -0.9, CAMERA_Z - 3.5]), 90.0

    limbs = figures.limbs(figures.RUNNER, path, outfit)
    brick, at = wall()
    meshes = [brick] + [m for m, _ in limbs]
    instances = [Instance(0, at)] + [Instance(i + 1, fn) for i, (_, fn) in enumerate(limbs)]
    t, prev_t = 0.5, 0.5 - 1 / 30
    hr = render_frame(meshes, instances, t)
    depth, motion = hr["depth"][..., 0].astype(np.float64), hr["motion"]
    h, w = depth.shape
    figure = depth < depth.max() - 1e-4
    assert figure.mean() > 0.005

    nx, ny = pixel_centres(h, w)
    ndc = np.stack([nx, ny, depth * 2 - 1, np.ones_like(depth)], -1)[figure]
    world = ndc @ np.linalg.inv(hr["view_proj"]).T
    world /= world[:, 3:]
    best = np.full(len(world), np.inf)
    for mesh, transform in limbs:  # each pixel moves as the limb that contains it
        local = world @ np.linalg.inv(transform(t)).T
        lo, hi = mesh.positions.min(0) - 1e-3, mesh.positions.max(0) + 1e-3
        inside = np.all((local[:, :3] >= lo) & (local[:, :3] <= hi), axis=1)
        prev = local @ (hr["view_proj"] @ transform(prev_t)).T
        prev_px = np.stack([(prev[:, 0] / prev[:, 3] + 1) / 2 * w, (1 - prev[:, 1] / prev[:, 3]) / 2 * h], -1)
        cur_px = np.stack([(nx[figure] + 1) / 2 * w, (1 - ny[figure]) / 2 * h], -1)
        error = np.linalg.norm(motion[figure] - (prev_px - cur_px), axis=-1)
        best = np.where(inside, np.minimum(best, error), best)
    assert np.isfinite(best).mean() > 0.95  # back-projected figure pixels lie on a limb
    assert np.median(best[np.isfinite(best)]) < 0.01
    assert (best < 0.05).mean() > 0.95
    spread = motion[figure].max(0) - motion[figure].min(0)
    assert spread.max() > 1.0  # limbs move unlike each other, not as one rigid body


@pytest.fixture(scope="module")
def tiny_garden(tmp_path_factory):
    root = tmp_path_factory.mktemp("garden")
    (root / "tiny.yaml").write_text(TINY)
    for out in ("a", "b"):
        render_dataset(load_render_config(str(root / "tiny.yaml")), root / out, progress=False)
    return root


def test_garden_and_plaza_pass_data_check_without_warnings(tiny_garden):
    report = check_dataset(tiny_garden / "a", progress=False)
    assert not report.errors and not report.warnings, [p.line() for p in report.problems]


def test_garden_renders_deterministically(tiny_garden):
    a, b = tiny_garden / "a", tiny_garden / "b"
    files = sorted(p.relative_to(a) for p in a.rglob("*.exr"))
    expected = {Path(seq, res, name, f"{f:05d}.exr") for seq, frames in (("garden", 5), ("plaza", 3))
                for res, name in (("lr", "color"), ("hr", "reference"), ("hr", "motion")) for f in range(frames)}
    assert expected <= set(files)
    for name in files:
        np.testing.assert_array_equal(read_exr(a / name), read_exr(b / name))


def test_only_held_out_configs_render_the_garden_and_only_training_configs_the_plaza():
    def users(scene: str) -> set[str]:
        return {p.stem for p in (CONFIG_DIR / "data").glob("*.yaml") if scene in {s.scene for s in load_render_config(str(p)).sequences}}

    assert users("garden") == {"garden_x2", "unseen_x2", "stress", "studio_garden_x2"}
    plaza = users("plaza")
    assert {"train_figures_x2", "train_engine_x2"} <= plaza and all(name.startswith("train_") for name in plaza)
    unseen = {s.name: s for s in load_render_config("unseen_x2").sequences}
    for seq in load_render_config("garden_x2").sequences:  # the same sequences (the native-AA references aside)
        assert dataclasses.replace(unseen[seq.name], extra_references=()) == dataclasses.replace(seq, extra_references=())


def test_the_runner_figure_is_drawn_by_the_garden_only():
    from mnss_kit.render import scenes

    package = CONFIG_DIR.parent / "render" / "scenes"
    drawers = {p.stem for p in package.glob("*.py") if "figures.RUNNER" in p.read_text()}
    assert drawers == {"garden"} and "garden" in scenes.BUILDERS
    assert figures.RUNNER != figures.WALKER and figures.RUNNER.rounded != figures.WALKER.rounded
