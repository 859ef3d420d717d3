"""What the renderer draws: meshes, instances whose transforms are functions of time, lights.

Every time-dependent quantity is a pure function of ``t`` (seconds), so any
frame can be rendered on its own: that gives byte-identical reruns and lets
shards render disjoint frames of one sequence.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .camera import CameraPath
from .mesh import Mesh

Transform = Callable[[float], np.ndarray]  # t -> (4, 4) float64 object-to-world


@dataclass
class Instance:
    mesh: int  # index into Scene.meshes
    transform: np.ndarray | Transform = field(default_factory=lambda: np.eye(4))

    def at(self, t: float) -> np.ndarray:
        m = self.transform
        return m(t) if callable(m) else m


@dataclass
class Sun:
    """Directional light; with ``animated`` the direction sweeps and the intensity flickers."""

    direction: tuple[float, float, float] = (0.4, 0.8, 0.3)  # towards the sun
    color: tuple[float, float, float] = (3.0, 2.8, 2.5)  # irradiance, linear RGB
    animated: bool = False

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        d = np.asarray(self.direction, dtype=np.float64)
        c = np.asarray(self.color, dtype=np.float64)
        if self.animated:
            a = 0.6 * t  # radians per second around the vertical axis
            d = np.array([d[0] * np.cos(a) - d[2] * np.sin(a), d[1], d[0] * np.sin(a) + d[2] * np.cos(a)])
            c = c * (0.75 + 0.25 * np.sin(7.3 * t) * np.sin(2.9 * t + 1.0))
        return d / np.linalg.norm(d), c


@dataclass
class Sky:
    zenith: tuple[float, float, float] = (0.25, 0.45, 0.95)
    horizon: tuple[float, float, float] = (0.75, 0.82, 0.9)
    ground: tuple[float, float, float] = (0.18, 0.16, 0.13)


# t -> ((P, 4) float32 centre xyz + radius, (P, 3) float32 radiance); additive, no depth write
ParticleSource = Callable[[float], tuple[np.ndarray, np.ndarray]]


@dataclass
class Scene:
    name: str
    meshes: list[Mesh]
    instances: list[Instance]
    camera: CameraPath
    sun: Sun = field(default_factory=Sun)
    sky: Sky = field(default_factory=Sky)
    near: float = 0.1
    far: float = 500.0
    shadow_radius: float = 40.0  # half extent (m) of the shadow map box around the view
    particles: ParticleSource | None = None


def static_instances(meshes: list[Mesh]) -> list[Instance]:
    return [Instance(i) for i in range(len(meshes))]
