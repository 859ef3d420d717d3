"""Back garden (held-out only): a lawn of alpha-tested grass cards, a picket fence, leafy bushes and
trees, a brick wall behind a paved path where articulated figures walk and run across.

The two contents engines draw everywhere and the training scenes barely show: cut-out foliage and
fences (every pass discards below the alpha cut, so the 16-sample reference is anti-aliased) and
figures whose limbs cross a textured background every frame.  The layout is fixed (the stress
cameras in ``configs/scenes/stress_figure.yaml`` and ``stress_foliage.yaml`` rely on it); the seed
varies textures, planting, figures and the generated camera.  No training config renders it.
"""

from __future__ import annotations

import numpy as np

from .. import shapes, textures
from ..camera import CameraPath
from ..mesh import Material
from ..scene import Scene, Sky, Sun
from . import common, figures

HALF_WIDTH = 20.0  # the garden spans x in [-HALF_WIDTH, HALF_WIDTH]
WALL_Z = -8.0  # brick wall (front face at WALL_Z + WALL_THICKNESS / 2)
WALL_THICKNESS = 0.4
PATH_Z = -5.5  # paved path the figures cross on
FENCE_Z = -2.0  # picket fence between the lawn and the path
FENCE_HEIGHT = 1.1
CROSS_RANGE = 12.0  # figures walk between x = -CROSS_RANGE and CROSS_RANGE


def build(seed: int, duration: float, start: float, camera: CameraPath | None, particles: bool, animated_light: bool) -> Scene:
    b = common.SceneBuilder("garden", seed)
    rng = b.rng
    mats = materials(rng)
    ground(b, mats)
    fence(b, mats)
    planting(b, rng, mats)
    runner = walkers(b, rng, mats, start + duration / 2)

    fx = None  # the feature flags draw no numbers from `rng`, so they leave the scene and camera unchanged
    if particles:  # pollen / midges drifting over the bed: light without depth or motion vectors
        origins = np.random.default_rng(seed).uniform((-6, 0.3, WALL_Z + 0.6), (6, 0.6, WALL_Z + 1.2), (5, 3))
        fx = common.sparks(origins, 40, seed, (1.5, 1.4, 0.6), rise=0.6, spread=0.4, life=2.0, radius=0.02)
    cam = camera or auto_camera(rng, start, duration, runner)
    sun = Sun((0.35, 0.7, 0.6), (3.1, 2.9, 2.5), animated_light)  # behind the camera side: the wall is lit, fence shadows fall on the path
    return b.build(cam, sun=sun, sky=Sky(), near=0.1, far=150.0, shadow_radius=20.0, particles=fx)


def materials(rng: np.random.Generator) -> dict[str, Material]:
    base = common.materials(rng)
    return {
        **base,
        "lawn": Material(base_color_texture=textures.grass(rng), roughness=0.95, name="lawn"),
        "paving": Material(base_color_texture=textures.tiles(rng, 256, 4, (0.5, 0.47, 0.42)), roughness=0.8, name="paving"),
        "brick": Material(base_color_texture=textures.bricks(rng, 256, 8, 4), roughness=0.9, name="brick"),
        "soil": Material(base_color_texture=textures.noise_colour(rng, 128, (0.18, 0.12, 0.07), 0.7, 16), roughness=1.0, name="soil"),
        "pickets": Material(base_color_texture=textures.pickets(rng), alpha_mode="mask", double_sided=True, roughness=0.7,
                            name="pickets"),
        "post": Material(base_color=(0.7, 0.68, 0.62), roughness=0.7, name="post"),
        "grass_cards": Material(base_color_texture=textures.grass_blades(rng), alpha_mode="mask", double_sided=True,
                                roughness=0.8, name="grass_cards"),
    }


def ground(b: common.SceneBuilder, mats: dict[str, Material]) -> None:
    """Lawn, the paved path, the planting bed and the brick wall behind it."""
    b.add(shapes.plane(2 * HALF_WIDTH, 40.0, mats["lawn"], uv_scale=3.0), shapes.translate(0, 0, 8.0))
    b.add(shapes.plane(2 * HALF_WIDTH, 2.5, mats["paving"], uv_scale=2.0), shapes.translate(0, 0.01, PATH_Z))
    b.add(shapes.plane(2 * HALF_WIDTH, 1.6, mats["soil"], uv_scale=2.0), shapes.translate(0, 0.005, WALL_Z + 1.0))
    b.add(shapes.box((2 * HALF_WIDTH, 3.0, WALL_THICKNESS), mats["brick"], 2.0), shapes.translate(0, 1.5, WALL_Z))


def fence(b: common.SceneBuilder, mats: dict[str, Material]) -> None:
    """Picket panels 2 m wide with square posts along the whole garden."""
    for x in np.arange(-HALF_WIDTH, HALF_WIDTH, 2.0):
        b.add(shapes.quad(2.0, FENCE_HEIGHT, mats["pickets"]), shapes.translate(x + 1.0, 0, FENCE_Z))
        b.add(shapes.box((0.1, FENCE_HEIGHT + 0.1, 0.1), mats["post"]), shapes.translate(x, (FENCE_HEIGHT + 0.1) / 2, FENCE_Z - 0.06))


def planting(b: common.SceneBuilder, rng: np.random.Generator, mats: dict[str, Material]) -> None:
    """Grass tufts along the fence and over the lawn, bushes in the bed, trees at the sides and behind."""
    for x in np.arange(-HALF_WIDTH + 0.3, HALF_WIDTH, 0.55):  # a dense row in front of the fence
        tuft(b, rng, x + rng.uniform(-0.15, 0.15), FENCE_Z + rng.uniform(0.25, 0.6), mats)
    for _ in range(160):
        tuft(b, rng, rng.uniform(-HALF_WIDTH, HALF_WIDTH), rng.uniform(FENCE_Z + 0.8, 14.0), mats)
    for x in np.arange(-HALF_WIDTH + 1.0, HALF_WIDTH, rng.uniform(2.2, 3.0)):  # bushes in the bed before the wall
        size = rng.uniform(0.7, 1.2)
        bush = shapes.cross_cards(size * 1.3, size, 3, mats["leaves"])
        b.add(bush, shapes.translate(x + rng.uniform(-0.4, 0.4), 0, WALL_Z + 0.9) @ shapes.rotate_y(float(rng.uniform(0, 180))))
    for x in (-HALF_WIDTH + 2.0, HALF_WIDTH - 2.0, *rng.uniform(-HALF_WIDTH, HALF_WIDTH, 3)):
        z = rng.uniform(3.0, 12.0) if abs(x) > HALF_WIDTH - 3 else WALL_Z - rng.uniform(1.5, 4.0)
        common.tree(b, float(x), float(z), rng.uniform(4.0, 6.5), mats["bark"], mats["leaves"])


def tuft(b: common.SceneBuilder, rng: np.random.Generator, x: float, z: float, mats: dict[str, Material]) -> None:
    size = rng.uniform(0.35, 0.6)
    card = shapes.cross_cards(size * 1.6, size, 2, mats["grass_cards"])
    b.add(card, shapes.translate(x, 0, z) @ shapes.rotate_y(float(rng.uniform(0, 180))))


def walkers(b: common.SceneBuilder, rng: np.random.Generator, mats: dict[str, Material], middle: float):
    """A runner and a walker crossing the centre of the path in opposite directions at ``middle`` (s),
    so every camera sees them; one or two more walkers at random places.  Returns the runner's path."""
    runner = crossing(rng, PATH_Z + 0.4, rng.uniform(3.0, 4.0), middle, forward=True)
    figures.add_figure(b, figures.RUNNER, runner, outfit(rng, mats))
    walker = crossing(rng, PATH_Z - 0.4, rng.uniform(1.2, 1.6), middle, forward=False)
    figures.add_figure(b, figures.WALKER, walker, outfit(rng, mats))
    for _ in range(int(rng.integers(1, 3))):
        path = common.line_path((-CROSS_RANGE, PATH_Z), (CROSS_RANGE, PATH_Z), rng.uniform(1.0, 1.5), rng.uniform(0, 4 * CROSS_RANGE))
        figures.add_figure(b, figures.WALKER, path, outfit(rng, mats))
    return runner


def crossing(rng: np.random.Generator, z: float, speed: float, middle: float, forward: bool):
    """A back-and-forth path along x at ``z`` that passes near x = 0 at time ``middle``."""
    length = 2 * CROSS_RANGE
    here = CROSS_RANGE + rng.uniform(-1.5, 1.5)  # arc length from the start point at ``middle``
    s = here if forward else 2 * length - here  # line_path walks a -> c, then back
    return common.line_path((-CROSS_RANGE, z), (CROSS_RANGE, z), speed, phase=(s - speed * middle) % (2 * length))


def outfit(rng: np.random.Generator, mats: dict[str, Material]) -> figures.Outfit:
    top, bottom = rng.uniform(0.08, 0.85, 3), rng.uniform(0.05, 0.5, 3)
    return figures.Outfit(common.cloth(rng, tuple(top)), common.cloth(rng, tuple(bottom)), mats["skin"])


def auto_camera(rng: np.random.Generator, start: float, duration: float, runner) -> CameraPath:
    """A strafe along the lawn looking through the grass and the fence, then a hard cut to a view from
    the path side of the fence that turns to follow the runner across the wall."""
    times = np.linspace(start, start + duration, 9)
    cut_at = int(rng.integers(4, 6))
    x0, z0, height = rng.uniform(-8, 8), rng.uniform(1.0, 3.5), rng.uniform(0.8, 1.6)
    velocity = rng.choice([-1, 1]) * rng.uniform(1.5, 3.0)
    glance = rng.uniform(-2.5, 2.5)
    side = rng.uniform(-3.0, 3.0)
    points = []
    for i, t in enumerate(times):
        if i < cut_at:
            eye = np.array([x0 + velocity * (t - start), height, z0])
            look = eye + (glance, -0.2 * height, -6.0)
        else:
            eye = np.array([side, 1.5, FENCE_Z - 0.8])
            runner_x = runner(t)[0][0]
            look = np.array([0.5 * (runner_x + side), 1.1, WALL_Z])
        points.append((t, eye, look, i == cut_at))
    return common.keyframes(points, rng.uniform(55, 65))
