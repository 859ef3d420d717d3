"""Town square (training): articulated walkers crossing before facades and a brick arcade wall.

The training-side companion of the held-out garden: it teaches what a figure's limbs uncover
(every limb its own instance with exact motion, ``figures.WALKER`` only; the runner stays held
out) on other content: paved ground, facades, planters with trees, lamp posts, no lawn, grass
cards or picket fence.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import shapes, textures
from ..camera import CameraPath
from ..mesh import Material
from ..scene import Scene, Sky, Sun
from . import common, figures

SIZE = 36.0  # the square spans [-SIZE/2, SIZE/2] in x and z


def build(seed: int, duration: float, start: float, camera: CameraPath | None, particles: bool, animated_light: bool) -> Scene:
    b = common.SceneBuilder("plaza", seed)
    rng = b.rng
    mats = common.materials(rng)
    paving = Material(base_color_texture=textures.tiles(rng, 256, 8, (0.55, 0.5, 0.44), 0.02), roughness=0.75, name="paving")
    brick = Material(base_color_texture=textures.bricks(rng, 256, 8, 4, (0.5, 0.3, 0.2)), roughness=0.9, name="brick")
    facades = [Material(base_color_texture=textures.facade(rng, 256, c), roughness=0.85, name="facade")
               for c in ((0.6, 0.55, 0.45), (0.5, 0.42, 0.38))]

    b.add(shapes.plane(SIZE * 2, SIZE * 2, paving, uv_scale=4.0))
    for k, (x, z, angle) in enumerate(((0, -SIZE / 2, 0), (-SIZE / 2, 0, 90), (SIZE / 2, 0, -90))):
        height = rng.uniform(8, 14)
        mat = brick if k == 0 else facades[k - 1]
        b.add(shapes.box((SIZE, height, 1.0), mat, 4.0), shapes.translate(x, height / 2, z) @ shapes.rotate_y(angle))
    for _ in range(int(rng.integers(4, 7))):  # planters with trees, lamp posts; none in the strip the camera faces the wall from
        x, z = rng.uniform(-SIZE / 2 + 3, SIZE / 2 - 3), rng.uniform(-4.0, SIZE / 2 - 3)
        b.add(shapes.box((1.2, 0.5, 1.2), brick, 1.0), shapes.translate(x, 0.25, z))
        common.tree(b, x, z, rng.uniform(3.0, 5.0), mats["bark"], mats["leaves"], y=0.5)
        b.add(shapes.cylinder(0.07, 4.5, 8, mats["metal"]), shapes.translate(x + 1.5, 0, z))

    crowd = []
    for k in range(int(rng.integers(6, 10))):  # walkers crossing the square, many along the brick wall
        a = (rng.uniform(-SIZE / 2 + 2, SIZE / 2 - 2), rng.uniform(-SIZE / 2 + 1.5, -SIZE / 2 + 5))
        along_wall = k == 0 or rng.random() < 0.6  # the first one, whom the camera watches, always
        heading = rng.uniform(-0.4, 0.4) + (0.0 if along_wall else math.pi / 2)
        c = np.clip((a[0] + 14 * math.cos(heading) * rng.choice([-1, 1]), a[1] + 14 * math.sin(heading)), -SIZE / 2 + 1.5, SIZE / 2 - 1.5)
        path = common.line_path(a, c, rng.uniform(1.1, 1.7), rng.uniform(0, 28))
        style = dataclasses.replace(figures.WALKER, height=rng.uniform(1.55, 1.9), cadence=rng.uniform(5.0, 6.2))
        outfit = figures.Outfit(common.cloth(rng, tuple(rng.uniform(0.1, 0.8, 3))), common.cloth(rng, tuple(rng.uniform(0.05, 0.5, 3))),
                                mats["skin"])
        figures.add_figure(b, style, path, outfit)
        crowd.append(path)

    fx = None  # the feature flags draw no numbers from `rng`, so they leave the scene and camera unchanged
    if particles:  # a fountain's spray in the middle of the square
        fx = common.sparks(np.array([(0.0, 0.6, 0.0)]), 300, seed, (1.2, 1.3, 1.5), rise=3.0, spread=0.5, life=1.2, radius=0.03)
    cam = camera or auto_camera(rng, start, duration, crowd[0])
    sun = Sun((0.3, 0.75, 0.55), (3.0, 2.8, 2.4), animated_light)
    return b.build(cam, sun=sun, sky=Sky(), near=0.1, far=200.0, shadow_radius=25.0, particles=fx)


def auto_camera(rng: np.random.Generator, start: float, duration: float, walker) -> CameraPath:
    """Eye level facing the brick wall, turning to watch a walker pass before it; then a cut to a high
    still viewpoint (above the tree crowns, inside the square) that turns to follow the walker."""
    times = np.linspace(start, start + duration, 9)
    cut_at = int(rng.integers(4, 7))
    first = walker(start)[0]
    eye0 = first + np.array([rng.uniform(-3, 3), rng.uniform(1.4, 1.8), rng.uniform(4, 7)])
    eye0[0] = np.clip(eye0[0], -SIZE / 2 + 4, SIZE / 2 - 4)  # clear of the side facades while drifting
    drift = np.array([rng.uniform(-1.5, 1.5), 0.0, rng.uniform(-0.5, 0.5)])
    high = walker(times[cut_at])[0] + (rng.uniform(-5, 5), rng.uniform(6.5, 8.0), rng.uniform(5, 8))
    high[[0, 2]] = np.clip(high[[0, 2]], -SIZE / 2 + 2, SIZE / 2 - 2)
    points = []
    for i, t in enumerate(times):
        if i < cut_at:
            eye = eye0 + drift * (t - start)
            look = np.array([walker(t)[0][0], 1.2, -SIZE / 2])
        else:
            eye, look = high, walker(t)[0] + (0, 1.0, 0)
        points.append((t, eye, look, i == cut_at))
    return common.keyframes(points, rng.uniform(55, 65))
