"""Flight over terrain: fields and hills, a lake, forests of cards, power lines, other aircraft."""

from __future__ import annotations

import math

import numpy as np

from .. import shapes, textures
from ..camera import CameraPath
from ..mesh import Material
from ..scene import Scene, Sky, Sun
from . import common

SIZE = 1600.0
GRID = 161
WATER = 4.0


def heights(rng: np.random.Generator) -> np.ndarray:
    """``(GRID, GRID)`` terrain heights in metres: rolling hills, a ridge and a lake basin."""
    base = textures.fbm(rng, 160, 2, 5)
    h = np.pad(base, ((0, 1), (0, 1)), mode="wrap") * 140.0 - 50.0
    y, x = np.mgrid[0:GRID, 0:GRID] / (GRID - 1) - 0.5
    h += 90.0 * np.exp(-((x - 0.3) ** 2) / 0.01)  # ridge
    return np.maximum(h, -5.0)


def sample_height(h: np.ndarray, x: float, z: float) -> float:
    """Bilinear terrain height at world (x, z)."""
    gx = np.clip((x / SIZE + 0.5) * (GRID - 1), 0, GRID - 1.001)
    gz = np.clip((z / SIZE + 0.5) * (GRID - 1), 0, GRID - 1.001)
    i, j = int(gz), int(gx)
    fz, fx = gz - i, gx - j
    top = h[i, j] * (1 - fx) + h[i, j + 1] * fx
    bottom = h[i + 1, j] * (1 - fx) + h[i + 1, j + 1] * fx
    return float(top * (1 - fz) + bottom * fz)


def build(seed: int, duration: float, start: float, camera: CameraPath | None, particles: bool, animated_light: bool) -> Scene:
    b = common.SceneBuilder("flight", seed)
    rng = b.rng
    mats = common.materials(rng)
    ground = Material(base_color_texture=textures.terrain(rng), roughness=0.9, name="terrain")
    water = Material(base_color=(0.02, 0.05, 0.07), roughness=0.08, name="water")
    roof = Material(base_color_texture=textures.planks(rng, 128, 10, (0.5, 0.15, 0.1)), roughness=0.7, name="roof")
    wall = Material(base_color_texture=textures.bricks(rng, 128, 6, 3, (0.7, 0.65, 0.55)), roughness=0.9, name="wall")
    paint = Material(base_color=(0.9, 0.9, 0.92), metallic=0.3, roughness=0.3, name="paint")

    h = heights(rng)
    b.add(shapes.heightfield(h, SIZE, ground, uv_scale=160.0))
    b.add(shapes.plane(SIZE, SIZE, water), shapes.translate(0, WATER, 0))

    def ground_y(x, z):
        return sample_height(h, x, z)

    forest = textures.fbm(rng, 64, 2, 4)
    for _ in range(4000):  # forests: alpha-tested cards on dry land where the forest noise is high
        x, z = rng.uniform(-SIZE / 2.2, SIZE / 2.2, 2)
        density = forest[int((z / SIZE + 0.5) * 63), int((x / SIZE + 0.5) * 63)]
        y = ground_y(x, z)
        if y > WATER + 2 and density > 0.55:
            common.tree(b, x, z, rng.uniform(8, 14), mats["bark"], mats["leaves"], y=y - 0.5)
    for _ in range(int(rng.integers(3, 5))):  # villages
        cx, cz = rng.uniform(-500, 500, 2)
        for _ in range(10):
            x, z = cx + rng.uniform(-40, 40), cz + rng.uniform(-40, 40)
            y = ground_y(x, z)
            if y < WATER + 1:
                continue
            w, d, hh = rng.uniform(6, 12), rng.uniform(6, 10), rng.uniform(4, 8)
            m = shapes.translate(x, y, z) @ shapes.rotate_y(float(rng.uniform(0, 90)))
            b.add(shapes.box((w, hh, d), wall, 3.0), m @ shapes.translate(0, hh / 2 - 1, 0))
            b.add(shapes.box((w * 1.1, 0.4, d * 1.1), roof, 2.0), m @ shapes.translate(0, hh - 0.8, 0))
    a = rng.uniform(0, np.pi)  # a power line crossing the map: pylons and sagging wires
    direction = np.array([math.cos(a), math.sin(a)])
    tops = []
    for s in np.arange(-700, 701, 70.0):
        x, z = direction * s
        y = ground_y(x, z)
        b.add(shapes.box((0.6, 24, 0.6), mats["metal"]), shapes.translate(x, y + 12, z))
        b.add(shapes.box((0.4, 0.4, 10), mats["metal"]), shapes.translate(x, y + 23, z) @ shapes.rotate_y(math.degrees(-a)))
        tops.append(np.array([x, y + 23, z]))
    side = np.array([-direction[1], 0, direction[0]]) * 4.5
    for p, q in zip(tops[:-1], tops[1:]):
        for off in (-side, side):
            b.add(shapes.wire(p + off, q + off, 0.05, mats["wire"], sag=5.0, pieces=8))
    for k in range(3):  # windmills with turning blades
        x, z = rng.uniform(-400, 400, 2)
        y = ground_y(x, z) + 30
        b.add(shapes.cylinder(0.8, 30, 10, paint, caps=True), shapes.translate(x, y - 30, z))
        blade = shapes.merge([shapes.transform(shapes.box((0.6, 12, 0.15), paint), shapes.rotate_z(120 * i) @ shapes.translate(0, 6, 0)) for i in range(3)])
        b.animate(blade, _rotor(x, y, z + 1.0, rng.uniform(40, 90)))
    plane = aircraft(paint)
    flights = []
    for k in range(3):
        centre, radius, alt, speed = rng.uniform(-300, 300, 2), rng.uniform(150, 300), rng.uniform(60, 110), rng.uniform(30, 45)
        flights.append((centre, alt))
        b.animate(plane, _orbit(centre, radius, alt, speed, rng.uniform(0, 6)))

    fx = None
    if particles:  # smoke-stack embers over the villages and a fireworks-like burst
        origins = np.array([(c[0], ground_y(c[0], c[1]) + 2.0, c[1]) for c, _ in flights])
        fx = common.sparks(origins, 300, seed, (6.0, 3.0, 1.0), rise=14.0, spread=5.0, life=3.0, radius=0.6)
    cam = camera or auto_camera(rng, start, duration, ground_y)
    sky = Sky(zenith=(0.18, 0.38, 0.95), horizon=(0.8, 0.85, 0.95), ground=(0.2, 0.2, 0.18))
    return b.build(cam, sun=Sun((0.3, 0.6, -0.5), (3.3, 3.1, 2.8), animated_light), sky=sky,
                   near=0.5, far=2500.0, shadow_radius=160.0, particles=fx)


def aircraft(material: Material):
    parts = [shapes.box((1.6, 1.6, 10), material), shapes.transform(shapes.box((12, 0.25, 2.0), material), shapes.translate(0, 0, -0.5)),
             shapes.transform(shapes.box((4, 0.2, 1.2), material), shapes.translate(0, 0, 4.2)),
             shapes.transform(shapes.box((0.2, 2.0, 1.2), material), shapes.translate(0, 1.0, 4.2))]
    return shapes.merge(parts)


def _rotor(x, y, z, degrees_per_second):
    return lambda t: shapes.translate(x, y, z) @ shapes.rotate_z(degrees_per_second * t)


def _orbit(centre, radius, alt, speed, phase):
    omega = speed / radius

    def transform(t: float) -> np.ndarray:
        a = phase + omega * t
        x, z = centre[0] + radius * math.cos(a), centre[1] + radius * math.sin(a)
        heading = math.degrees(math.atan2(-math.sin(a), math.cos(a)))  # tangent direction
        return shapes.translate(x, alt, z) @ shapes.rotate_y(heading + 180) @ shapes.rotate_z(-25)

    return transform


def auto_camera(rng: np.random.Generator, start: float, duration: float, ground_y) -> CameraPath:
    """Fly low over the terrain with banked turns, one fast look-around, and a hard cut."""
    n = 10
    times = np.linspace(start, start + duration, n)
    speed = rng.uniform(35, 55)
    heading = rng.uniform(0, 2 * np.pi)
    turn = rng.uniform(-0.25, 0.25)
    pos = np.array([rng.uniform(-300, 300), 0.0, rng.uniform(-300, 300)])
    pan_at, cut_at = int(rng.integers(2, 5)), int(rng.integers(6, 8))
    points = []
    dt = times[1] - times[0]
    for i, t in enumerate(times):
        if i == cut_at:  # jump to a different area
            jump = rng.uniform(250, 400, 2) * rng.choice([-1, 1], 2)
            pos = pos + np.array([jump[0], 0.0, jump[1]])
            heading += rng.uniform(1.5, 3.0)
        forward = np.array([math.sin(heading), 0.0, -math.cos(heading)])
        altitude = max(ground_y(pos[0], pos[2]), WATER) + rng.uniform(35, 60)
        eye = np.array([pos[0], altitude, pos[2]])
        look_dir = forward.copy()
        if i == pan_at:  # glance sideways fast
            side = rng.choice([-1, 1])
            look_dir = np.array([math.sin(heading + side * 1.4), 0.0, -math.cos(heading + side * 1.4)])
        look = eye + look_dir * 100.0 + np.array([0, -35.0, 0])
        points.append((t, eye, look, i == cut_at))
        pos = pos + forward * speed * dt
        heading += turn * dt
    return common.keyframes(points, rng.uniform(55, 65))
