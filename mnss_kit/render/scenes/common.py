"""Building blocks shared by the built-in scenes: static batching, props, characters, sparks."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from .. import shapes, textures
from ..camera import CameraPath, KeyframeConfig
from ..mesh import Material, Mesh
from ..scene import Instance, ParticleSource, Scene


class SceneBuilder:
    """Collects static meshes (merged per material at the end) and animated instances."""

    def __init__(self, name: str, seed: int):
        self.name = name
        self.rng = np.random.default_rng(seed)
        self.static: dict[int, list[Mesh]] = {}
        self.dynamic: list[tuple[Mesh, np.ndarray | Callable[[float], np.ndarray]]] = []

    def add(self, mesh: Mesh, m: np.ndarray | None = None) -> None:
        mesh = mesh if m is None else shapes.transform(mesh, m)
        self.static.setdefault(id(mesh.material), []).append(mesh)

    def animate(self, mesh: Mesh, transform: Callable[[float], np.ndarray]) -> None:
        self.dynamic.append((mesh, transform))

    def build(self, camera: CameraPath, **scene_args) -> Scene:
        meshes = [shapes.merge(group) for group in self.static.values()]
        instances = [Instance(i) for i in range(len(meshes))]
        for mesh, fn in self.dynamic:
            instances.append(Instance(len(meshes), fn))
            meshes.append(mesh)
        return Scene(self.name, meshes, instances, camera, **scene_args)


def tree(b: SceneBuilder, x: float, z: float, height: float, bark: Material, leaves: Material, y: float = 0.0) -> None:
    """Trunk plus crossed alpha-tested foliage cards."""
    b.add(shapes.cylinder(0.12 * height / 4, height * 0.6, 6, bark), shapes.translate(x, y, z))
    crown = shapes.cross_cards(height * 0.7, height * 0.75, 3, leaves)
    b.add(crown, shapes.translate(x, y + height * 0.3, z) @ shapes.rotate_y(float(b.rng.uniform(0, 180))))


def fence(b: SceneBuilder, a, c, height: float, mesh_mat: Material, post_mat: Material) -> None:
    """Chain-link panels between posts from ``a`` to ``c`` (x, z) with a top rail wire."""
    a, c = np.asarray(a, float), np.asarray(c, float)
    length = float(np.linalg.norm(c - a))
    panels = max(1, int(round(length / 3.0)))
    angle = math.degrees(math.atan2(-(c[1] - a[1]), c[0] - a[0]))
    for i in range(panels + 1):
        p = a + (c - a) * i / panels
        b.add(shapes.cylinder(0.04, height, 6, post_mat), shapes.translate(p[0], 0, p[1]))
    for i in range(panels):
        p = a + (c - a) * (i + 0.5) / panels
        b.add(shapes.quad(length / panels, height, mesh_mat), shapes.translate(p[0], 0, p[1]) @ shapes.rotate_y(angle))
    b.add(shapes.wire((a[0], height, a[1]), (c[0], height, c[1]), 0.025, post_mat))


def character(b: SceneBuilder, path: Callable[[float], tuple[np.ndarray, float]], height: float,
              cloth: Material, skin: Material, stride: float = 6.0) -> None:
    """A walking box figure; ``path(t) -> (position (3,), heading degrees)``; limbs swing with time."""
    h = height

    def root(t: float) -> np.ndarray:
        p, heading = path(t)
        bob = 0.02 * h * abs(math.sin(stride * t))
        return shapes.translate(p[0], p[1] + bob, p[2]) @ shapes.rotate_y(heading)

    def limb(pivot, phase: float, amplitude: float):
        return lambda t: root(t) @ shapes.translate(*pivot) @ shapes.rotate_x(amplitude * math.sin(stride * t + phase))

    b.animate(shapes.merge([shapes.transform(shapes.box((0.36 * h, 0.38 * h, 0.2 * h), cloth, 0.5), shapes.translate(0, 0.66 * h, 0))]), root)
    b.animate(shapes.transform(shapes.sphere(0.11 * h, 6, 10, skin), shapes.translate(0, 0.93 * h, 0)), root)
    leg = shapes.transform(shapes.box((0.13 * h, 0.47 * h, 0.14 * h), cloth, 0.5), shapes.translate(0, -0.235 * h, 0))
    arm = shapes.transform(shapes.box((0.09 * h, 0.4 * h, 0.1 * h), skin, 0.5), shapes.translate(0, -0.2 * h, 0))
    for side, phase in ((-1, 0.0), (1, math.pi)):
        b.animate(leg, limb((side * 0.09 * h, 0.47 * h, 0), phase, 30.0))
        b.animate(arm, limb((side * 0.24 * h, 0.83 * h, 0), phase + math.pi, 35.0))


def loop_path(centre, radius: float, speed: float, phase: float, y: float = 0.0, rx: float = 1.0, rz: float = 1.0):
    """Walk an ellipse at ``speed`` m/s; returns ``path(t) -> (position, heading)``."""
    cx, cz = centre
    omega = speed / radius

    def path(t: float):
        a = phase + omega * t
        pos = np.array([cx + radius * rx * math.cos(a), y, cz + radius * rz * math.sin(a)])
        vx, vz = -rx * math.sin(a), rz * math.cos(a)
        return pos, math.degrees(math.atan2(vx, vz))

    return path


def line_path(a, c, speed: float, phase: float, y: float = 0.0):
    """Walk back and forth between ``a`` and ``c`` (x, z)."""
    a, c = np.asarray(a, float), np.asarray(c, float)
    length = float(np.linalg.norm(c - a))

    def path(t: float):
        s = (phase + speed * t) % (2 * length)
        forward = s < length
        f = s / length if forward else 2 - s / length
        p = a + (c - a) * f
        d = (c - a) if forward else (a - c)
        return np.array([p[0], y, p[1]]), math.degrees(math.atan2(d[0], d[1]))

    return path


def sparks(origins: np.ndarray, per_origin: int, seed: int, colour, rise: float = 2.0, spread: float = 0.6,
           life: float = 1.5, radius: float = 0.06) -> ParticleSource:
    """Rising, fading additive sparks above each origin; a pure function of time."""
    rng = np.random.default_rng(seed)
    n = len(origins) * per_origin
    base = np.repeat(np.asarray(origins, np.float64), per_origin, axis=0)
    phase = rng.random(n)
    vel = np.stack([rng.normal(0, spread, n), rng.uniform(0.5, 1.0, n) * rise, rng.normal(0, spread, n)], 1)
    col = np.asarray(colour, np.float64)[None, :] * rng.uniform(0.5, 1.5, (n, 1))

    def source(t: float):
        age = (t / life + phase) % 1.0  # in [0, 1): particle respawns every `life` seconds
        sec = age * life
        pos = base + vel * sec[:, None] - np.outer(0.5 * 0.8 * sec**2, (0, 1, 0))
        fade = (1.0 - age) ** 2
        centres = np.concatenate([pos, np.full((n, 1), radius)], 1)
        return centres.astype(np.float32), (col * fade[:, None]).astype(np.float32)

    return source


def keyframes(points: list[tuple], fov: float) -> CameraPath:
    """Camera path from ``(time, position, look_at, cut)`` tuples."""
    return CameraPath([KeyframeConfig(time=float(t), position=tuple(map(float, p)), look_at=tuple(map(float, q)), cut=cut)
                       for t, p, q, cut in points], fov)


def materials(rng: np.random.Generator) -> dict[str, Material]:
    """The material set every built-in scene draws from (textures differ per seed)."""
    leaf = textures.leaves(rng)
    return {
        "bark": Material(base_color_texture=textures.planks(rng, 128, 3, (0.25, 0.16, 0.1)), roughness=0.9, name="bark"),
        "leaves": Material(base_color_texture=leaf, alpha_mode="mask", double_sided=True, roughness=0.7, name="leaves"),
        "chainlink": Material(base_color_texture=textures.chainlink(), alpha_mode="mask", double_sided=True,
                              metallic=1.0, roughness=0.45, name="chainlink"),
        "metal": Material(base_color=(0.55, 0.55, 0.58), metallic=1.0, roughness=0.35, name="metal"),
        "wire": Material(base_color=(0.05, 0.05, 0.05), roughness=0.6, name="wire"),
        "stripes": Material(base_color_texture=textures.stripes(), roughness=0.5, double_sided=True, name="stripes"),
        "skin": Material(base_color=(0.75, 0.55, 0.42), roughness=0.6, name="skin"),
    }


def cloth(rng: np.random.Generator, colour) -> Material:
    return Material(base_color_texture=textures.noise_colour(rng, 64, colour, 0.6, 16), roughness=0.8, name="cloth")
