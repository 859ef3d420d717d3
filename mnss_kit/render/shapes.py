"""Procedural geometry for the built-in scenes: primitives, baking transforms, merging.

Every builder returns a ``Mesh`` in object space with counter-clockwise front
faces.  UVs are in world-ish units (one texture repeat per ``uv_scale`` metres)
so textures keep a constant density across differently sized boxes.
"""

from __future__ import annotations

import math

import numpy as np

from .mesh import Material, Mesh


def translate(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def scale(sx: float, sy: float | None = None, sz: float | None = None) -> np.ndarray:
    return np.diag([sx, sx if sy is None else sy, sx if sz is None else sz, 1.0])


def rotate_y(degrees: float) -> np.ndarray:
    a = math.radians(degrees)
    m = np.eye(4)
    m[0, 0], m[0, 2], m[2, 0], m[2, 2] = math.cos(a), math.sin(a), -math.sin(a), math.cos(a)
    return m


def rotate_x(degrees: float) -> np.ndarray:
    a = math.radians(degrees)
    m = np.eye(4)
    m[1, 1], m[1, 2], m[2, 1], m[2, 2] = math.cos(a), -math.sin(a), math.sin(a), math.cos(a)
    return m


def rotate_z(degrees: float) -> np.ndarray:
    a = math.radians(degrees)
    m = np.eye(4)
    m[0, 0], m[0, 1], m[1, 0], m[1, 1] = math.cos(a), -math.sin(a), math.sin(a), math.cos(a)
    return m


def box(size=(1.0, 1.0, 1.0), material: Material | None = None, uv_scale: float = 1.0, name: str = "box") -> Mesh:
    """Axis-aligned box centred at the origin, 24 vertices (flat normals)."""
    half = np.asarray(size, dtype=np.float64) / 2.0
    positions, normals, uvs, indices = [], [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            u_axis, v_axis = [(2, 1), (0, 2), (0, 1)][axis]
            u = np.zeros(3)
            u[u_axis] = 1.0
            v = np.cross(n, u)
            base = len(positions)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = n * half + u * a * half + v * b * half
                positions.append(p)
                normals.append(n)
                uvs.append((a * half[u_axis] / uv_scale, -b * np.abs(v) @ half / uv_scale))
            indices += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return Mesh(np.array(positions), np.array(normals), np.array(uvs), np.array(indices), material or Material(), name)


def plane(width: float, depth: float, material: Material | None = None, uv_scale: float = 1.0, name: str = "plane") -> Mesh:
    """Horizontal quad (normal +y) centred at the origin."""
    w, d = width / 2.0, depth / 2.0
    pos = np.array([(-w, 0, d), (w, 0, d), (w, 0, -d), (-w, 0, -d)])
    uv = pos[:, [0, 2]] / uv_scale
    return Mesh(pos, np.tile((0, 1, 0), (4, 1)), uv, [(0, 1, 2), (0, 2, 3)], material or Material(), name)


def quad(width: float, height: float, material: Material | None = None, name: str = "quad") -> Mesh:
    """Vertical quad in the x-y plane (normal +z), bottom edge on y = 0, uv over [0, 1]^2."""
    w = width / 2.0
    pos = np.array([(-w, 0, 0), (w, 0, 0), (w, height, 0), (-w, height, 0)])
    uv = np.array([(0, 1), (1, 1), (1, 0), (0, 0)])
    return Mesh(pos, np.tile((0, 0, 1), (4, 1)), uv, [(0, 1, 2), (0, 2, 3)], material or Material(), name)


def cylinder(radius: float, height: float, segments: int = 12, material: Material | None = None, name: str = "cylinder",
             caps: bool = False) -> Mesh:
    """Vertical cylinder from y = 0 to y = height, smooth sides; ``caps`` closes both ends."""
    a = np.linspace(0.0, 2 * np.pi, segments + 1)
    ring = np.stack([np.sin(a), np.zeros_like(a), np.cos(a)], axis=1)
    pos = np.concatenate([ring * radius, ring * radius + (0, height, 0)])
    uv = np.concatenate([np.stack([a / (2 * np.pi), np.full_like(a, 1.0)], 1), np.stack([a / (2 * np.pi), np.zeros_like(a)], 1)])
    n = segments + 1
    idx = [(i, i + 1, n + i + 1) for i in range(segments)] + [(i, n + i + 1, n + i) for i in range(segments)]
    side = Mesh(pos, np.concatenate([ring, ring]), uv, idx, material or Material(), name)
    if not caps:
        return side
    disk_pos = np.concatenate([[(0.0, 0.0, 0.0)], ring[:-1] * radius])
    fan = [(0, 1 + i, 1 + (i + 1) % segments) for i in range(segments)]  # counter-clockwise seen from +y
    disk = Mesh(disk_pos, np.tile((0, 1, 0), (segments + 1, 1)), disk_pos[:, [0, 2]] / (2 * radius) + 0.5, fan, side.material)
    top = transform(disk, translate(0, height, 0))
    bottom = transform(disk, rotate_x(180.0))
    return merge([side, top, bottom], name)


def sphere(radius: float, rings: int = 8, segments: int = 12, material: Material | None = None, name: str = "sphere") -> Mesh:
    theta = np.linspace(0, np.pi, rings + 1)[:, None]
    phi = np.linspace(0, 2 * np.pi, segments + 1)[None, :]
    n = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta) * np.ones_like(phi), np.sin(theta) * np.cos(phi)], -1).reshape(-1, 3)
    uv = np.stack(np.broadcast_arrays(phi / (2 * np.pi), theta / np.pi), -1).reshape(-1, 2)
    c = segments + 1
    idx = [(r * c + s, (r + 1) * c + s, (r + 1) * c + s + 1) for r in range(rings) for s in range(segments)]
    idx += [(r * c + s, (r + 1) * c + s + 1, r * c + s + 1) for r in range(rings) for s in range(segments)]
    return Mesh(n * radius, n, uv, idx, material or Material(), name)


def wire(a, b, radius: float, material: Material | None = None, segments: int = 5, sag: float = 0.0, pieces: int = 1) -> Mesh:
    """Thin cylinder(s) from point ``a`` to ``b``; with ``sag`` a catenary-like droop (metres)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    s = np.linspace(0.0, 1.0, pieces + 1)
    pts = a + (b - a) * s[:, None] - np.outer(4 * sag * s * (1 - s), (0, 1, 0))
    parts = [_segment(p, q, radius, material, segments) for p, q in zip(pts[:-1], pts[1:])]
    return merge(parts)


def _segment(a: np.ndarray, b: np.ndarray, radius: float, material: Material | None, segments: int) -> Mesh:
    d = b - a
    length = float(np.linalg.norm(d))
    y = d / length
    x = np.cross(y, (0, 0, 1) if abs(y[2]) < 0.9 else (1, 0, 0))
    x /= np.linalg.norm(x)
    z = np.cross(x, y)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, a
    return transform(cylinder(radius, length, segments, material), m)


def cross_cards(width: float, height: float, count: int, material: Material, name: str = "cards") -> Mesh:
    """``count`` vertical quads rotated around y (foliage, grass tufts); alpha-tested material."""
    return merge([transform(quad(width, height, material), rotate_y(180.0 * i / count)) for i in range(count)], name)


def heightfield(heights: np.ndarray, size: float, material: Material, uv_scale: float = 4.0, name: str = "terrain") -> Mesh:
    """Grid mesh over ``[-size/2, size/2]^2`` from ``heights`` (N, N) metres; smooth normals."""
    n = heights.shape[0]
    xs = np.linspace(-size / 2, size / 2, n)
    gx, gz = np.meshgrid(xs, xs)
    pos = np.stack([gx, heights, gz], -1).reshape(-1, 3)
    step = size / (n - 1)
    dz, dx = np.gradient(heights, step)
    normals = np.stack([-dx, np.ones_like(dx), -dz], -1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    idx = np.concatenate([np.stack([a, a + n, a + n + 1], 1), np.stack([a, a + n + 1, a + 1], 1)])
    return Mesh(pos, normals.reshape(-1, 3), pos[:, [0, 2]] / uv_scale, idx, material, name)


def transform(mesh: Mesh, m: np.ndarray) -> Mesh:
    """Copy of ``mesh`` with the ``(4, 4)`` transform baked in (normals by the inverse transpose)."""
    p = mesh.positions.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    nm = np.linalg.inv(m[:3, :3]).T
    n = mesh.normals.astype(np.float64) @ nm.T
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    idx = mesh.indices if np.linalg.det(m[:3, :3]) > 0 else mesh.indices[:, ::-1]
    return Mesh(p, n, mesh.uvs, idx, mesh.material, mesh.name)


def merge(meshes: list[Mesh], name: str | None = None) -> Mesh:
    """One mesh from several that share the first one's material (fewer draw calls)."""
    offsets = np.cumsum([0] + [len(m.positions) for m in meshes[:-1]])
    return Mesh(
        np.concatenate([m.positions for m in meshes]),
        np.concatenate([m.normals for m in meshes]),
        np.concatenate([m.uvs for m in meshes]),
        np.concatenate([m.indices + o for m, o in zip(meshes, offsets)]),
        meshes[0].material,
        name or meshes[0].name,
    )
