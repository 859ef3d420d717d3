"""First-person street: facades, shop lights, wires overhead, fences, pedestrians, a passing car."""

from __future__ import annotations

import math

import numpy as np

from .. import shapes, textures
from ..camera import CameraPath
from ..mesh import Material
from ..scene import Scene, Sky, Sun
from . import common

LENGTH = 120.0  # street runs along z from +LENGTH/2 to -LENGTH/2
ROAD = 8.0
WALK = 3.0


def build(seed: int, duration: float, start: float, camera: CameraPath | None, particles: bool, animated_light: bool) -> Scene:
    b = common.SceneBuilder("town", seed)
    rng = b.rng
    mats = common.materials(rng)
    asphalt = Material(base_color_texture=textures.noise_colour(rng, 256, (0.09, 0.09, 0.1), 0.8, 32), roughness=0.7, name="asphalt")
    pavement = Material(base_color_texture=textures.tiles(rng, 256, 8, (0.5, 0.48, 0.45), 0.04), roughness=0.8, name="pavement")
    marking = Material(base_color=(0.9, 0.85, 0.6), roughness=0.6, name="marking")
    glow = Material(base_color=(0.2, 0.18, 0.12), emissive=(1.6, 1.2, 0.6), roughness=0.4, name="shop_light")
    facades = [Material(base_color_texture=textures.facade(rng, 256, c), roughness=0.85, name="facade")
               for c in ((0.55, 0.48, 0.4), (0.45, 0.3, 0.25), (0.6, 0.6, 0.58))]
    brick = Material(base_color_texture=textures.bricks(rng), roughness=0.9, name="brick")

    b.add(shapes.plane(ROAD, LENGTH, asphalt, uv_scale=4.0))
    for z in np.arange(-LENGTH / 2 + 2, LENGTH / 2, 6.0):  # dashed centre line
        b.add(shapes.plane(0.15, 3.0, marking), shapes.translate(0, 0.01, z))
    for side in (-1, 1):
        x_walk = side * (ROAD + WALK) / 2
        b.add(shapes.box((WALK, 0.15, LENGTH), pavement, 2.0), shapes.translate(x_walk, 0.075, 0))
        z = -LENGTH / 2
        while z < LENGTH / 2:  # buildings of varying width, height and depth
            width, height = rng.uniform(8, 16), rng.uniform(7, 22)
            depth = rng.uniform(8, 12)
            x = side * (ROAD / 2 + WALK + depth / 2)
            mat = facades[int(rng.integers(len(facades)))] if rng.random() > 0.2 else brick
            b.add(shapes.box((depth, height, width), mat, 7.0), shapes.translate(x, height / 2, z + width / 2))
            if rng.random() < 0.6:  # lit shop window and a striped awning
                xf = side * (ROAD / 2 + WALK) - side * 0.01
                b.add(shapes.quad(width * 0.6, 1.8, glow), shapes.translate(xf, 0.6, z + width / 2) @ shapes.rotate_y(-side * 90))
                b.add(shapes.quad(width * 0.7, 1.2, mats["stripes"]),
                      shapes.translate(xf - side * 0.6, 3.0, z + width / 2) @ shapes.rotate_y(-side * 90) @ shapes.rotate_x(-50))
            z += width + rng.uniform(0.0, 2.5)
    for z in np.arange(-LENGTH / 2 + 5, LENGTH / 2, 14.0):  # lamp posts and sagging overhead wires
        for side in (-1, 1):
            x = side * (ROAD / 2 + 0.5)
            b.add(shapes.cylinder(0.08, 6.0, 8, mats["metal"]), shapes.translate(x, 0.15, z))
            b.add(shapes.sphere(0.25, 6, 8, glow), shapes.translate(x, 6.2, z))
        for h in (6.0, 6.4):
            b.add(shapes.wire((-ROAD / 2 - 0.5, h, z), (ROAD / 2 + 0.5, h, z), 0.015, mats["wire"], sag=0.4, pieces=6))
        b.add(shapes.wire((-ROAD / 2 - 0.5, 5.9, z), (-ROAD / 2 - 0.5, 5.9, z + 14), 0.015, mats["wire"], sag=0.6, pieces=6))
    for _ in range(4):  # fenced gaps and planters
        z = rng.uniform(-LENGTH / 2 + 5, LENGTH / 2 - 5)
        side = rng.choice([-1, 1])
        x = side * (ROAD / 2 + 0.3)
        common.fence(b, (x, z), (x, z + rng.uniform(4, 8)), 1.2, mats["chainlink"], mats["metal"])
    for z in rng.uniform(-LENGTH / 2, LENGTH / 2, 8):
        x = rng.choice([-1, 1]) * (ROAD / 2 + WALK - 0.6)
        b.add(shapes.box((0.9, 0.6, 0.9), brick, 1.0), shapes.translate(x, 0.45, z))
        common.tree(b, x, z, rng.uniform(2.0, 3.0), mats["bark"], mats["leaves"], y=0.75)

    for k in range(int(rng.integers(8, 12))):  # pedestrians on both pavements
        side = rng.choice([-1, 1])
        x = side * (ROAD / 2 + rng.uniform(0.6, WALK - 0.5))
        path = common.line_path((x, -LENGTH / 2 + 5), (x, LENGTH / 2 - 5), rng.uniform(1.0, 1.6), rng.uniform(0, 200), y=0.15)
        colour = tuple(rng.uniform(0.1, 0.8, 3))
        common.character(b, path, rng.uniform(1.6, 1.9), common.cloth(rng, colour), mats["skin"], stride=5.0)
    car = Material(base_color=tuple(rng.uniform(0.1, 0.9, 3)), metallic=1.0, roughness=0.25, name="car")
    body = shapes.merge([shapes.transform(shapes.box((1.8, 0.7, 4.2), car), shapes.translate(0, 0.65, 0)),
                         shapes.transform(shapes.box((1.6, 0.6, 2.2), car), shapes.translate(0, 1.3, -0.3))])
    speed = rng.uniform(8, 12)
    b.animate(body, lambda t: shapes.translate(-ROAD / 4, 0, ((t * speed) % (LENGTH + 40)) - LENGTH / 2 - 20))
    b.animate(shapes.box((0.05, 1.2, 1.2), mats["metal"]), lambda t: shapes.translate(ROAD / 2 + WALK - 0.3, 4.0, 10.0) @ shapes.rotate_x(200 * t))

    fx = None  # the feature flags draw no numbers from `rng`, so they leave the scene and camera unchanged
    if particles:  # welding sparks and a bonfire barrel
        origins = np.array([(ROAD / 2 + 1.0, 0.9, z) for z in np.random.default_rng(seed).uniform(-30, 30, 3)])
        fx = common.sparks(origins, 120, seed, (6.0, 3.0, 0.8), rise=3.0, spread=1.2, life=1.0, radius=0.04)
    cam = camera or auto_camera(rng, start, duration)
    sun = Sun((-0.45, 0.55, 0.3), (3.0, 2.3, 1.6), animated_light)
    sky = Sky(zenith=(0.2, 0.32, 0.7), horizon=(0.95, 0.7, 0.5), ground=(0.15, 0.12, 0.1))
    return b.build(cam, sun=sun, sky=sky, near=0.1, far=300.0, shadow_radius=30.0, particles=fx)


def auto_camera(rng: np.random.Generator, start: float, duration: float) -> CameraPath:
    """Eye-level walk down the street with look-arounds, a fast whip pan, and a hard cut."""
    n = 10
    times = np.linspace(start, start + duration, n)
    speed = rng.uniform(1.5, 3.0)
    lane = rng.uniform(-2.5, 2.5)
    z0 = rng.uniform(20, 40)
    pan_at, cut_at = int(rng.integers(2, 5)), int(rng.integers(6, 8))
    points = []
    for i, t in enumerate(times):
        z = z0 - speed * (t - start)
        yaw = 25.0 * math.sin(1.3 * i + rng.uniform(0, 1))
        if i == pan_at:
            yaw += rng.choice([-1, 1]) * rng.uniform(70, 110)  # whip pan
        x = lane
        if i >= cut_at:
            z -= 35.0 + (0.0 if i == cut_at else 0.0)
            x = -lane
        pos = np.array([x, 1.7 + 0.04 * math.sin(9.0 * t), z])
        look = pos + np.array([-math.sin(math.radians(yaw)), rng.uniform(-0.15, 0.1), -math.cos(math.radians(yaw))]) * 5.0
        points.append((t, pos, look, i == cut_at))
    return common.keyframes(points, rng.uniform(65, 75))
