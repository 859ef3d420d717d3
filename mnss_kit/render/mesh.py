"""Geometry and material records shared by the built-in scenes and the glTF/OBJ importers.

Everything is plain numpy so scenes can be built, imported and tested without
a GL context; ``render`` uploads them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np


@dataclass
class Material:
    base_color: tuple[float, float, float] = (0.8, 0.8, 0.8)  # linear RGB, multiplies the texture
    base_color_texture: np.ndarray | None = None  # (H, W, 3|4) uint8, sRGB-encoded; alpha in channel 3
    roughness: float = 0.5
    metallic: float = 0.0
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)  # linear RGB radiance
    alpha_mode: Literal["opaque", "mask", "blend"] = "opaque"
    alpha_cutoff: float = 0.5
    double_sided: bool = False
    name: str = ""


@dataclass
class Mesh:
    positions: np.ndarray  # (V, 3) float32, object space
    normals: np.ndarray  # (V, 3) float32, unit length
    uvs: np.ndarray  # (V, 2) float32; v grows downwards in the texture (glTF convention)
    indices: np.ndarray  # (T, 3) uint32, counter-clockwise front faces
    material: Material = field(default_factory=Material)
    name: str = ""

    def __post_init__(self):
        self.positions = np.ascontiguousarray(self.positions, dtype=np.float32).reshape(-1, 3)
        self.normals = np.ascontiguousarray(self.normals, dtype=np.float32).reshape(-1, 3)
        self.uvs = np.ascontiguousarray(self.uvs, dtype=np.float32).reshape(-1, 2)
        self.indices = np.ascontiguousarray(self.indices, dtype=np.uint32).reshape(-1, 3)
        n = len(self.positions)
        if len(self.normals) != n or len(self.uvs) != n:
            raise ValueError(f"mesh '{self.name}': positions, normals and uvs must have the same length")
        if self.indices.size and int(self.indices.max()) >= n:
            raise ValueError(f"mesh '{self.name}': index out of range")
