"""Industrial interior: a hall with a polished floor, pipe runs, grated catwalks with thin rails,
roof trusses under skylight slots, emissive strip lights, machines, an overhead crane, a forklift.

Lit unlike the outdoor scenes: a dim ambient sky, the sun entering only through the skylight slots
(sharp shafts of light on the floor and machines) and emissive fixtures.  The renderer has no
point lights, so the strip lights and indicator panels glow without lighting their surroundings.
"""

from __future__ import annotations

import math

import numpy as np

from .. import shapes, textures
from ..camera import CameraPath
from ..mesh import Material
from ..scene import Scene, Sky, Sun
from . import common

LENGTH = 90.0  # the hall runs along z from +LENGTH/2 to -LENGTH/2
WIDTH = 24.0
HEIGHT = 11.0
CATWALK = 4.5  # catwalk deck height (m)
BAY = 7.5  # column spacing along z


def build(seed: int, duration: float, start: float, camera: CameraPath | None, particles: bool, animated_light: bool) -> Scene:
    b = common.SceneBuilder("factory", seed)
    rng = b.rng
    mats = materials(rng)
    shell(b, mats)
    for side in (-1, 1):
        pipe_run(b, rng, side, mats)
        catwalk(b, side, mats)
    machines(b, rng, mats)
    moving_parts(b, rng, mats)

    fx = None  # the feature flags draw no numbers from `rng`, so they leave the scene and camera unchanged
    if particles:  # grinding sparks at the machines
        origins = np.array([(x, 1.3, z) for x, z in np.random.default_rng(seed).uniform((-3, -30), (3, 30), (4, 2))])
        fx = common.sparks(origins, 150, seed, (7.0, 3.5, 1.0), rise=1.5, spread=1.5, life=0.8, radius=0.03)
    cam = camera or auto_camera(rng, start, duration)
    sun = Sun((0.35, 0.85, -0.4), (9.0, 7.5, 5.5), animated_light)  # strong: it reaches the floor through slots only
    sky = Sky(zenith=(0.05, 0.06, 0.08), horizon=(0.07, 0.065, 0.06), ground=(0.03, 0.03, 0.03))
    return b.build(cam, sun=sun, sky=sky, near=0.1, far=200.0, shadow_radius=28.0, particles=fx)


def materials(rng: np.random.Generator) -> dict[str, Material]:
    base = common.materials(rng)
    return {
        "floor": Material(base_color_texture=textures.tiles(rng, 256, 2, (0.32, 0.33, 0.34), 0.006), roughness=0.12,
                          name="polished_concrete"),
        "wall": Material(base_color_texture=textures.stripes(64, 16, (0.42, 0.45, 0.47), (0.3, 0.32, 0.34)), metallic=0.6,
                         roughness=0.45, name="corrugated_steel"),
        "steel": Material(base_color=(0.2, 0.22, 0.25), metallic=0.8, roughness=0.4, name="painted_steel"),
        "copper": Material(base_color=(0.95, 0.6, 0.4), metallic=1.0, roughness=0.3, name="copper"),
        "green_pipe": Material(base_color=(0.1, 0.35, 0.2), roughness=0.35, name="green_pipe"),
        "rail": Material(base_color=(0.85, 0.65, 0.05), roughness=0.5, name="yellow_rail"),
        "grating": Material(base_color_texture=textures.grating(), alpha_mode="mask", double_sided=True, metallic=1.0,
                            roughness=0.5, name="grating"),
        "hazard": Material(base_color_texture=textures.stripes(64, 8, (0.9, 0.7, 0.05), (0.03, 0.03, 0.03)), roughness=0.6,
                           double_sided=True, name="hazard"),
        "strip_light": Material(base_color=(0.9, 0.9, 0.9), emissive=(6.0, 6.2, 6.5), name="strip_light"),
        "indicator": [Material(base_color=(0.05, 0.05, 0.05), emissive=tuple(3.0 * np.asarray(c)), name="indicator")
                      for c in ((0.2, 1.0, 0.3), (1.0, 0.15, 0.1), (0.2, 0.5, 1.0))],
        "machine": [Material(base_color=c, metallic=0.3, roughness=0.35, name="machine")
                    for c in ((0.12, 0.3, 0.5), (0.55, 0.12, 0.08), (0.5, 0.5, 0.48))],
        "crate": Material(base_color_texture=textures.planks(rng, 128, 5, (0.42, 0.3, 0.16)), roughness=0.85, name="crate"),
        "chainlink": base["chainlink"],
        "skin": base["skin"],
    }


def shell(b: common.SceneBuilder, mats: dict) -> None:
    """Floor, walls, columns, roof slabs with skylight slots between them, trusses, strip lights."""
    b.add(shapes.plane(WIDTH, LENGTH, mats["floor"], uv_scale=6.0))
    for side in (-1, 1):
        b.add(shapes.box((0.4, HEIGHT, LENGTH), mats["wall"], 1.0), shapes.translate(side * (WIDTH / 2 + 0.2), HEIGHT / 2, 0))
        b.add(shapes.box((WIDTH, HEIGHT, 0.4), mats["wall"], 1.0), shapes.translate(0, HEIGHT / 2, side * (LENGTH / 2 + 0.2)))
    for z in np.arange(-LENGTH / 2 + BAY, LENGTH / 2, BAY):
        for side in (-1, 1):  # I-beam columns: web and two flanges
            x = side * (WIDTH / 2 - 0.5)
            b.add(shapes.box((0.08, HEIGHT, 0.4), mats["steel"]), shapes.translate(x, HEIGHT / 2, z))
            for dz in (-0.2, 0.2):
                b.add(shapes.box((0.45, HEIGHT, 0.05), mats["steel"]), shapes.translate(x, HEIGHT / 2, z + dz))
        b.add(shapes.box((WIDTH, 0.5, 0.25), mats["steel"]), shapes.translate(0, HEIGHT - 0.6, z))  # truss chord
        for k in range(12):  # truss diagonals: thin members against the skylights
            x0 = -WIDTH / 2 + k * WIDTH / 12
            b.add(shapes.wire((x0, HEIGHT - 0.85, z), (x0 + WIDTH / 12, HEIGHT - 2.0 if k % 2 else HEIGHT - 0.85, z), 0.04,
                              mats["steel"]))
        b.add(shapes.wire((-WIDTH / 2, HEIGHT - 2.0, z), (WIDTH / 2, HEIGHT - 2.0, z), 0.05, mats["steel"]))
    slab = BAY - 1.6  # each bay's roof leaves a 1.6 m skylight slot
    for z in np.arange(-LENGTH / 2, LENGTH / 2, BAY):
        b.add(shapes.box((WIDTH + 1, 0.3, slab), mats["steel"]), shapes.translate(0, HEIGHT + 0.15, z + slab / 2))
        for x in (-6.0, 0.0, 6.0):  # strip lights hanging under the slabs
            b.add(shapes.box((0.25, 0.08, slab * 0.7), mats["strip_light"]), shapes.translate(x, HEIGHT - 2.6, z + slab / 2))
            for dz in (-0.3, 0.3):
                b.add(shapes.wire((x, HEIGHT - 2.55, z + slab / 2 + dz * slab), (x, HEIGHT, z + slab / 2 + dz * slab), 0.01,
                                  mats["steel"]))


def pipe_run(b: common.SceneBuilder, rng: np.random.Generator, side: int, mats: dict) -> None:
    """Horizontal pipes along one wall at several heights, flanges, and drops to the floor."""
    x_wall = side * (WIDTH / 2 - 0.4)
    for level, (height, radius, mat) in enumerate(((1.2, 0.25, "green_pipe"), (2.2, 0.12, "copper"), (2.7, 0.08, "copper"),
                                                   (7.5, 0.35, "steel"), (8.3, 0.18, "green_pipe"))):
        x = x_wall - side * (radius + 0.05 + 0.1 * level)
        b.add(shapes.wire((x, height, -LENGTH / 2), (x, height, LENGTH / 2), radius, mats[mat], segments=14))
        for z in np.arange(-LENGTH / 2 + 3, LENGTH / 2, rng.uniform(5, 7)):  # flanges
            b.add(shapes.wire((x, height, z), (x, height, z + 0.1), radius * 1.35, mats["steel"], segments=14))
    for z in rng.uniform(-LENGTH / 2 + 4, LENGTH / 2 - 4, 5):  # vertical drops with a valve wheel
        x = x_wall - side * 1.4
        b.add(shapes.cylinder(0.1, 7.5, 12, mats["copper"]), shapes.translate(x, 0, z))
        b.add(shapes.box((0.04, 0.5, 0.5), mats["rail"]), shapes.translate(x - side * 0.12, 1.4, z))


def catwalk(b: common.SceneBuilder, side: int, mats: dict) -> None:
    """A grated deck along one wall with posts, two thin handrails and a hazard edge."""
    width = 1.8
    x = side * (WIDTH / 2 - 1.6 - width / 2)
    b.add(shapes.plane(width, LENGTH, mats["grating"], uv_scale=1.0), shapes.translate(x, CATWALK, 0))
    edge = x - side * width / 2
    b.add(shapes.box((0.03, 0.15, LENGTH), mats["hazard"], 0.4), shapes.translate(edge, CATWALK - 0.075, 0))
    for z in np.arange(-LENGTH / 2, LENGTH / 2 + 0.1, 1.5):
        b.add(shapes.cylinder(0.025, 1.1, 6, mats["rail"]), shapes.translate(edge, CATWALK, z))
    for h in (0.55, 1.1):
        b.add(shapes.wire((edge, CATWALK + h, -LENGTH / 2), (edge, CATWALK + h, LENGTH / 2), 0.02, mats["rail"]))
    for z in np.arange(-LENGTH / 2 + BAY / 2, LENGTH / 2, 2 * BAY):  # hangers to the trusses
        b.add(shapes.wire((edge, CATWALK, z), (edge, HEIGHT - 0.6, z), 0.015, mats["steel"]))


def machines(b: common.SceneBuilder, rng: np.random.Generator, mats: dict) -> None:
    """Machines with indicator panels, fenced cells, crates and barrels on both sides of the aisle."""
    for z in np.arange(-LENGTH / 2 + 5, LENGTH / 2 - 4, 9.0):
        for side in (-1, 1):
            if rng.random() < 0.25:
                continue
            w, h, d = rng.uniform(2, 3.5), rng.uniform(1.5, 3.2), rng.uniform(2, 4)
            x = side * rng.uniform(4.0, 6.5)
            mat = mats["machine"][int(rng.integers(len(mats["machine"])))]
            b.add(shapes.box((w, h, d), mat), shapes.translate(x, h / 2, z))
            panel = mats["indicator"][int(rng.integers(len(mats["indicator"])))]
            b.add(shapes.quad(w * 0.3, 0.25, panel), shapes.translate(x - side * (w / 2 + 0.01), h * 0.6, z) @ shapes.rotate_y(-side * 90))
            b.add(shapes.plane(w + 1.0, d + 1.0, mats["hazard"], uv_scale=1.2), shapes.translate(x, 0.005, z))
            if rng.random() < 0.5:  # a fenced cell beside the machine
                zf = z + d / 2 + 0.8
                common.fence(b, (x - side * 1.5, zf), (x + side * 1.5, zf), 2.0, mats["chainlink"], mats["rail"])
    for _ in range(14):  # barrels and crates near the walls
        x, z = rng.choice([-1, 1]) * rng.uniform(7.5, 9.0), rng.uniform(-LENGTH / 2 + 2, LENGTH / 2 - 2)
        if rng.random() < 0.5:
            b.add(shapes.cylinder(0.3, 0.9, 12, mats["machine"][1], caps=True), shapes.translate(x, 0, z))
        else:
            s = rng.uniform(0.8, 1.3)
            b.add(shapes.box((s, s, s), mats["crate"], 0.5), shapes.translate(x, s / 2, z) @ shapes.rotate_y(float(rng.uniform(0, 90))))


def moving_parts(b: common.SceneBuilder, rng: np.random.Generator, mats: dict) -> None:
    """The overhead crane, a forklift in the aisle, a ceiling fan, workers on the floor and catwalks."""
    crane_speed, crane_phase = rng.uniform(1.5, 2.5), rng.uniform(0, 100)
    beam = shapes.merge([shapes.box((WIDTH - 1, 0.6, 0.5), mats["rail"]),
                         shapes.transform(shapes.box((0.8, 0.8, 0.8), mats["steel"]), shapes.translate(0, -0.6, 0))])
    b.animate(beam, lambda t: shapes.translate(0, HEIGHT - 3.3, _ping_pong(crane_phase + crane_speed * t, LENGTH - 10)))
    hook = shapes.wire((0, 0, 0), (0, -3.5, 0), 0.02, mats["steel"])
    b.animate(hook, lambda t: shapes.translate(0, HEIGHT - 3.9, _ping_pong(crane_phase + crane_speed * t, LENGTH - 10))
              @ shapes.rotate_x(8 * math.sin(1.7 * t)))
    lift = shapes.merge([shapes.transform(shapes.box((1.2, 1.0, 2.0), mats["hazard"]), shapes.translate(0, 0.6, 0)),
                         shapes.transform(shapes.box((1.1, 0.08, 1.0), mats["steel"]), shapes.translate(0, 0.2, 1.5))])
    lift_speed, lift_phase = rng.uniform(2.5, 4.0), rng.uniform(0, 100)
    b.animate(lift, lambda t: shapes.translate(1.5, 0, _ping_pong(lift_phase + lift_speed * t, LENGTH - 12)))
    fan = shapes.merge([shapes.box((3.0, 0.05, 0.3), mats["steel"]), shapes.box((0.3, 0.05, 3.0), mats["steel"])])
    b.animate(fan, lambda t: shapes.translate(0, HEIGHT - 1.2, BAY / 2) @ shapes.rotate_y(240 * t))
    for k in range(int(rng.integers(5, 8))):
        deck = k % 3 == 0  # some on the catwalks
        if deck:
            x, y = rng.choice([-1, 1]) * (WIDTH / 2 - 2.5), CATWALK
        else:
            x, y = rng.uniform(-2.5, 2.5), 0.0
        path = common.line_path((x, -LENGTH / 2 + 5), (x, LENGTH / 2 - 5), rng.uniform(0.9, 1.5), rng.uniform(0, 150), y=y)
        common.character(b, path, rng.uniform(1.65, 1.85), common.cloth(rng, (0.9, 0.45, 0.1)), mats["skin"], stride=5.0)


def _ping_pong(s: float, span: float) -> float:
    """Position in [-span/2, span/2] moving back and forth at unit speed in ``s``."""
    s = s % (2 * span)
    return (s if s < span else 2 * span - s) - span / 2


def auto_camera(rng: np.random.Generator, start: float, duration: float) -> CameraPath:
    """A low glide down the aisle looking along the pipes, a fast pan up to the trusses, a hard cut
    to a catwalk view across the hall."""
    n = 9
    times = np.linspace(start, start + duration, n)
    speed = rng.uniform(2.0, 3.5)
    z0, x0 = rng.uniform(15, 35), rng.uniform(-1.5, 1.5)
    pan_at, cut_at = int(rng.integers(2, 4)), int(rng.integers(5, 7))
    side = rng.choice([-1, 1])
    points = []
    for i, t in enumerate(times):
        if i < cut_at:
            pos = np.array([x0, 2.0 + 0.8 * math.sin(0.7 * i), z0 - speed * (t - start)])
            yaw = 30.0 * math.sin(1.1 * i + rng.uniform(0, 1))
            pitch = 0.6 if i == pan_at else rng.uniform(-0.1, 0.05)  # the pan looks up at the roof
            if i == pan_at:
                yaw += side * rng.uniform(50, 80)
        else:  # on a catwalk, looking across and down into the hall
            pos = np.array([side * (WIDTH / 2 - 2.5), CATWALK + 1.6, z0 - 40.0 - 1.2 * (t - times[cut_at])])
            yaw, pitch = side * 90.0 + rng.uniform(-20, 20), -0.35
        look = pos + np.array([-math.sin(math.radians(yaw)), pitch, -math.cos(math.radians(yaw))]) * 5.0
        points.append((t, pos, look, i == cut_at))
    return common.keyframes(points, rng.uniform(60, 72))
