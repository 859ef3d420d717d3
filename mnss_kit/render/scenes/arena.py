"""MOBA-style arena seen from a high, tilted camera: tiled plaza, lanes, towers, jungle, minions."""

from __future__ import annotations

import math

import numpy as np

from .. import shapes, textures
from ..camera import CameraPath
from ..mesh import Material
from ..scene import Scene, Sky, Sun
from . import common

SIZE = 80.0


def build(seed: int, duration: float, start: float, camera: CameraPath | None, particles: bool, animated_light: bool) -> Scene:
    b = common.SceneBuilder("arena", seed)
    rng = b.rng
    mats = common.materials(rng)
    floor = Material(base_color_texture=textures.tiles(rng, 256, 4, (0.45, 0.42, 0.38)), roughness=0.75, name="floor")
    lane = Material(base_color_texture=textures.planks(rng, 256, 8, (0.4, 0.3, 0.18)), roughness=0.8, name="lane")
    grass = Material(base_color_texture=textures.grass(rng), roughness=0.95, name="grass")
    wall = Material(base_color_texture=textures.bricks(rng, 256, 8, 4, (0.35, 0.33, 0.4)), roughness=0.85, name="wall")
    gold = Material(base_color=(1.0, 0.78, 0.35), metallic=1.0, roughness=0.25, name="gold")
    teams = [Material(base_color=c, emissive=tuple(4.0 * np.asarray(c)), roughness=0.3, name="crystal") for c in ((0.2, 0.5, 1.0), (1.0, 0.25, 0.15))]

    b.add(shapes.plane(SIZE, SIZE, floor, uv_scale=6.0))
    for z0 in (-SIZE / 4, SIZE / 4):  # jungle grass patches
        b.add(shapes.plane(SIZE * 0.9, SIZE / 3, grass, uv_scale=4.0), shapes.translate(0, 0.01, z0))
    b.add(shapes.plane(6.0, SIZE, lane, uv_scale=3.0), shapes.translate(0, 0.02, 0))  # mid lane (planks)
    b.add(shapes.plane(6.0, SIZE * 1.3, lane, uv_scale=3.0), shapes.translate(0, 0.025, 0) @ shapes.rotate_y(45))
    for side in (-1, 1):  # border walls
        b.add(shapes.box((SIZE, 2.0, 1.0), wall, 2.0), shapes.translate(0, 1.0, side * SIZE / 2))
        b.add(shapes.box((1.0, 2.0, SIZE), wall, 2.0), shapes.translate(side * SIZE / 2, 1.0, 0))

    towers = []
    for team, z in ((0, 30.0), (1, -30.0)):
        for x in (-14.0, 0.0, 14.0):
            x1, z1 = x + rng.uniform(-2, 2), z - np.sign(z) * rng.uniform(0, 6)
            towers.append((x1, z1))
            b.add(shapes.cylinder(1.4, 5.0, 16, wall, caps=True), shapes.translate(x1, 0, z1))
            b.add(shapes.cylinder(1.6, 0.4, 16, gold, caps=True), shapes.translate(x1, 5.0, z1))
            crystal = shapes.sphere(0.7, 6, 8, teams[team])
            b.animate(crystal, _spin(x1, z1, 6.5, rng.uniform(0, 6)))
    for _ in range(int(rng.integers(26, 34))):  # jungle trees away from the lanes
        x, z = rng.uniform(-37, 37), rng.uniform(-37, 37)
        if abs(x) > 5 and abs(x - z) > 7 and min(math.hypot(x - tx, z - tz) for tx, tz in towers) > 4:
            common.tree(b, x, z, rng.uniform(3.5, 6.0), mats["bark"], mats["leaves"])
    for _ in range(6):  # fenced pens with thin posts and rails
        x, z = rng.uniform(-30, 30), rng.uniform(-30, 30)
        a = rng.uniform(0, np.pi)
        d = np.array([math.cos(a), math.sin(a)]) * rng.uniform(4, 9)
        common.fence(b, (x, z), (x + d[0], z + d[1]), 1.4, mats["chainlink"], mats["metal"])
    for x, z in towers[::2]:  # banners (hard stripes) on poles with wires
        b.add(shapes.quad(1.5, 1.0, mats["stripes"]), shapes.translate(x + 2.5, 3.0, z) @ shapes.rotate_y(20))
        b.add(shapes.wire((x + 1.6, 4.2, z), (x + 3.5, 3.0, z + 1.0), 0.02, mats["wire"], sag=0.3, pieces=4))

    for k in range(int(rng.integers(10, 14))):  # minion waves walking the lanes
        team = k % 2
        a, c = ((0, -36), (0, 36)) if k % 4 < 2 else ((-30, -30), (30, 30))
        path = common.line_path(a, c, rng.uniform(2.0, 3.0), phase=rng.uniform(0, 60))
        common.character(b, path, rng.uniform(0.9, 1.2), common.cloth(rng, ((0.2, 0.3, 0.8), (0.8, 0.2, 0.15))[team]), mats["skin"])
    hero = common.loop_path((rng.uniform(-8, 8), rng.uniform(-8, 8)), rng.uniform(7, 11), 4.0, rng.uniform(0, 6), rz=0.7)
    common.character(b, hero, 1.9, common.cloth(rng, (0.7, 0.6, 0.1)), mats["skin"], stride=8.0)

    fx = None
    if particles:
        origins = np.array([(x, 6.6, z) for x, z in towers])
        fx = common.sparks(origins, 60, seed, (4.0, 2.0, 6.0), rise=2.5, spread=0.8, radius=0.1)
    cam = camera or auto_camera(rng, start, duration, hero)
    return b.build(cam, sun=Sun((0.5, 0.75, 0.35), (3.2, 2.9, 2.5), animated_light), sky=Sky(),
                   near=0.5, far=250.0, shadow_radius=32.0, particles=fx)


def _spin(x: float, z: float, y: float, phase: float):
    return lambda t: shapes.translate(x, y + 0.3 * math.sin(2.0 * t + phase), z) @ shapes.rotate_y(90.0 * t)


def auto_camera(rng: np.random.Generator, start: float, duration: float, hero) -> CameraPath:
    """High tilted view following the hero, a fast pan across the map, then a hard cut."""
    height, back = rng.uniform(16, 22), rng.uniform(9, 13)
    times = np.linspace(start, start + duration, 9)
    cut_at, pan_at = int(rng.integers(5, 7)), int(rng.integers(2, 4))
    offset = np.array([rng.uniform(-18, 18), 0.0, rng.uniform(-18, 18)])
    cut_focus = np.array([rng.uniform(-25, 25), 0.0, rng.uniform(-25, 25)])
    drift = np.array([rng.uniform(-2, 2), 0.0, rng.uniform(-2, 2)])
    points = []
    for i, t in enumerate(times):
        if i < cut_at:  # follow the hero; from pan_at on, look at another part of the map
            look = hero(t)[0] + (offset if i >= pan_at else 0.0)
        else:
            look = cut_focus + drift * (t - times[cut_at])
        points.append((t, look + (0.0, height, back), look, i == cut_at))
    if pan_at + 1 < len(points):  # squeeze the pan into a quarter of its interval
        t0, t1 = times[pan_at - 1], times[pan_at]
        points[pan_at] = (t0 + 0.25 * (t1 - t0), *points[pan_at][1:])
    return common.keyframes(points, rng.uniform(40, 50))
