"""Procedural textures in numpy: deterministic for a seed, tileable, high-frequency on purpose.

Every generator returns ``(N, N, 4)`` uint8 sRGB-encoded RGBA (the
``Material.base_color_texture`` layout), row 0 at the top (v = 0).  Fine
detail (mortar lines, chain links, leaf edges, planks) is what makes aliasing,
moire and shimmer visible, which is what the supersampling models must handle.
"""

from __future__ import annotations

import numpy as np

from ..ops.colour import srgb_encode


def value_noise(rng: np.random.Generator, size: int, cells: int) -> np.ndarray:
    """Tileable smooth noise ``(size, size)`` float32 in [0, 1] from a ``cells x cells`` lattice."""
    lattice = rng.random((cells, cells))
    t = np.arange(size) * cells / size
    i0 = np.floor(t).astype(int)
    f = t - i0
    f = f * f * (3 - 2 * f)
    i1 = (i0 + 1) % cells
    rows = lattice[i0] * (1 - f)[:, None] + lattice[i1] * f[:, None]
    out = rows[:, i0] * (1 - f)[None, :] + rows[:, i1] * f[None, :]
    return out.astype(np.float32)


def fbm(rng: np.random.Generator, size: int, base_cells: int = 4, octaves: int = 5) -> np.ndarray:
    """Fractal sum of value noise, normalised to [0, 1]."""
    total = np.zeros((size, size), np.float32)
    amp, norm = 1.0, 0.0
    for o in range(octaves):
        cells = min(base_cells * 2**o, size)
        total += amp * value_noise(rng, size, cells)
        norm += amp
        amp *= 0.5
    return total / norm


def to_rgba8(linear_rgb: np.ndarray, alpha: np.ndarray | None = None) -> np.ndarray:
    """Linear RGB ``(N, N, 3)`` (+ alpha in [0, 1]) -> sRGB-encoded uint8 RGBA."""
    rgb = srgb_encode(np.clip(linear_rgb, 0.0, 1.0))
    a = np.ones(rgb.shape[:2], np.float32) if alpha is None else np.clip(alpha, 0.0, 1.0)
    out = np.concatenate([rgb, a[..., None]], axis=-1)
    return np.round(out * 255.0).astype(np.uint8)


def _tint(base, amount: np.ndarray) -> np.ndarray:
    return np.asarray(base, np.float32)[None, None, :] * amount[..., None]


def _grid(size: int) -> tuple[np.ndarray, np.ndarray]:
    u = (np.arange(size) + 0.5) / size
    return np.meshgrid(u, u)  # x, y in [0, 1)


def bricks(rng, size=256, rows=8, cols=4, colour=(0.45, 0.17, 0.1), mortar=(0.55, 0.53, 0.5)) -> np.ndarray:
    """Running-bond bricks with thin mortar lines and per-brick tint."""
    x, y = _grid(size)
    row = np.floor(y * rows)
    bx = x * cols + 0.5 * (row % 2)
    col = np.floor(bx)
    fx, fy = bx - col, y * rows - row
    line = (np.minimum(fx, 1 - fx) < 0.04) | (np.minimum(fy, 1 - fy) < 0.08)
    tint = rng.uniform(0.7, 1.2, (rows, cols + 1))[row.astype(int), (col % (cols + 1)).astype(int)]
    grain = 0.8 + 0.4 * fbm(rng, size, 8, 4)
    rgb = np.where(line[..., None], _tint(mortar, grain), _tint(colour, tint * grain))
    return to_rgba8(rgb)


def tiles(rng, size=256, count=4, colour=(0.42, 0.4, 0.37), gap=0.03) -> np.ndarray:
    """Square stone tiles with dark grout and per-tile variation."""
    x, y = _grid(size)
    fx, fy = (x * count) % 1.0, (y * count) % 1.0
    grout = (np.minimum(fx, 1 - fx) < gap) | (np.minimum(fy, 1 - fy) < gap)
    tint = rng.uniform(0.65, 1.25, (count, count))[(y * count).astype(int), (x * count).astype(int)]
    grain = 0.7 + 0.6 * fbm(rng, size, 8, 5)
    rgb = _tint(colour, tint * grain)
    rgb[grout] *= 0.25
    return to_rgba8(rgb)


def planks(rng, size=256, count=6, colour=(0.36, 0.2, 0.09)) -> np.ndarray:
    """Wooden planks: stripes with grain along x and dark seams."""
    x, y = _grid(size)
    fy = (y * count) % 1.0
    seam = np.minimum(fy, 1 - fy) < 0.04
    idx = (y * count).astype(int)
    grain = 0.75 + 0.25 * np.sin(2 * np.pi * (x * 3 + 6 * value_noise(rng, size, 8) + idx * 0.37) * 4)
    tint = rng.uniform(0.75, 1.2, count)[idx]
    rgb = _tint(colour, grain * tint)
    rgb[seam] *= 0.3
    return to_rgba8(rgb)


def grass(rng, size=256, colour=(0.12, 0.28, 0.05), dirt=(0.3, 0.22, 0.12)) -> np.ndarray:
    """Grass with speckles and dirt patches."""
    patches = fbm(rng, size, 4, 5)
    speck = rng.random((size, size)).astype(np.float32)
    mix = np.clip((patches - 0.55) * 5, 0, 1)[..., None]
    rgb = _tint(colour, 0.6 + 0.8 * speck) * (1 - mix) + _tint(dirt, 0.7 + 0.5 * speck) * mix
    return to_rgba8(rgb)


def terrain(rng, size=512) -> np.ndarray:
    """Ground cover for the flight scene: fields, rock and crisp field boundaries."""
    x, y = _grid(size)
    fields = rng.integers(0, 4, (8, 8))[(y * 8).astype(int), (x * 8).astype(int)]
    palette = np.array([(0.1, 0.25, 0.05), (0.35, 0.3, 0.1), (0.16, 0.2, 0.06), (0.3, 0.22, 0.12)], np.float32)
    n = fbm(rng, size, 8, 5)
    rgb = palette[fields] * (0.65 + 0.7 * n)[..., None]
    rows = (np.sin(2 * np.pi * (x + y * (fields % 2)) * 96) > 0.6) & (fields == 1)  # crop rows
    rgb[rows] *= 0.55
    edge = (np.minimum((x * 8) % 1, 1 - (x * 8) % 1) < 0.01) | (np.minimum((y * 8) % 1, 1 - (y * 8) % 1) < 0.01)
    rgb[edge] = (0.05, 0.1, 0.03)  # hedges
    return to_rgba8(rgb)


def facade(rng, size=256, wall=(0.55, 0.5, 0.42), floors=4, windows=3) -> np.ndarray:
    """Building wall with a grid of dark framed windows."""
    x, y = _grid(size)
    wx, wy = (x * windows) % 1.0, (y * floors) % 1.0
    window = (np.abs(wx - 0.5) < 0.28) & (np.abs(wy - 0.5) < 0.3)
    frame = (np.abs(wx - 0.5) < 0.32) & (np.abs(wy - 0.5) < 0.34) & ~window
    mullion = window & ((np.abs(wx - 0.5) < 0.02) | (np.abs(wy - 0.45) < 0.02))
    grain = 0.8 + 0.4 * fbm(rng, size, 8, 4)
    rgb = _tint(wall, grain)
    rgb[window] = (0.04, 0.06, 0.08)
    rgb[frame | mullion] = (0.85, 0.85, 0.8)
    return to_rgba8(rgb)


def chainlink(size=128, links=8) -> np.ndarray:
    """Diamond wire mesh: thin metal wires (alpha 1) and holes (alpha 0)."""
    x, y = _grid(size)
    a, b = ((x + y) * links) % 1.0, ((x - y) * links) % 1.0
    wire = (np.minimum(a, 1 - a) < 0.07) | (np.minimum(b, 1 - b) < 0.07)
    rgb = np.broadcast_to(np.float32(0.55), (size, size, 3))
    return to_rgba8(rgb, wire.astype(np.float32))


def grating(size=128, bars=8, width=0.12) -> np.ndarray:
    """Square floor grating: a grid of thin metal bars (alpha 1) with square holes (alpha 0)."""
    x, y = _grid(size)
    fx, fy = (x * bars) % 1.0, (y * bars) % 1.0
    bar = (np.minimum(fx, 1 - fx) < width / 2) | (np.minimum(fy, 1 - fy) < width / 2)
    rgb = np.broadcast_to(np.float32(0.5), (size, size, 3))
    return to_rgba8(rgb, bar.astype(np.float32))


def leaves(rng, size=256, colour=(0.08, 0.22, 0.04), count=140) -> np.ndarray:
    """Foliage card: many small elliptic leaves on a transparent background."""
    x, y = _grid(size)
    alpha = np.zeros((size, size), np.float32)
    tint = np.ones((size, size), np.float32)
    for cx, cy, ang, shade in zip(rng.random(count), rng.random(count) * 0.85 + 0.1, rng.random(count) * np.pi, rng.uniform(0.6, 1.4, count)):
        weight = max(0.0, 1.0 - abs(cx - 0.5) * 1.5 - abs(cy - 0.45) * 1.2)  # rounder crown
        if weight <= 0.05:
            continue
        dx, dy = x - cx, y - cy
        u = dx * np.cos(ang) + dy * np.sin(ang)
        v = -dx * np.sin(ang) + dy * np.cos(ang)
        leaf = (u / 0.05) ** 2 + (v / 0.02) ** 2 < 1.0
        alpha[leaf] = 1.0
        tint[leaf] = shade
    return to_rgba8(_tint(colour, tint), alpha)


def stripes(size=64, count=8, a=(0.8, 0.78, 0.7), b=(0.08, 0.08, 0.08)) -> np.ndarray:
    """Hard stripes (road markings, awnings, hazard bars): worst case for moire."""
    x, _ = _grid(size)
    on = ((x * count) % 1.0) < 0.5
    return to_rgba8(np.where(on[..., None], np.float32(a), np.float32(b)).astype(np.float32))


def noise_colour(rng, size=128, colour=(0.5, 0.5, 0.5), contrast=0.5, cells=8) -> np.ndarray:
    """Plain material with fine noise (cloth, skin, rock)."""
    return to_rgba8(_tint(colour, 1 - contrast / 2 + contrast * fbm(rng, size, cells, 4)))


def pickets(rng, size=256, boards=6, colour=(0.75, 0.72, 0.66)) -> np.ndarray:
    """Picket fence panel: boards with pointed tops and two rails (alpha 1), gaps between (alpha 0)."""
    x, y = _grid(size)
    fx = (x * boards) % 1.0
    board = np.abs(fx - 0.5) < 0.3
    tip = y > 0.08 + 0.35 * np.abs(fx - 0.5)  # pointed tops: y grows downwards
    rail = (np.abs(y - 0.3) < 0.035) | (np.abs(y - 0.8) < 0.035)
    solid = (board & tip) | rail
    tint = rng.uniform(0.8, 1.1, boards)[(x * boards).astype(int)]
    grain = 0.85 + 0.3 * fbm(rng, size, 8, 4)
    return to_rgba8(_tint(colour, tint * grain), solid.astype(np.float32))


def grass_blades(rng, size=256, colour=(0.1, 0.3, 0.05), count=90) -> np.ndarray:
    """Grass card: tapered, slightly bent blades growing from the bottom edge on a transparent background."""
    x, y = _grid(size)
    alpha = np.zeros((size, size), np.float32)
    tint = np.ones((size, size), np.float32)
    height = 1.0 - y  # 0 at the bottom edge, 1 at the top
    for root, tall, lean, width, shade in zip(rng.random(count), rng.uniform(0.35, 0.95, count), rng.uniform(-0.15, 0.15, count),
                                              rng.uniform(0.008, 0.02, count), rng.uniform(0.6, 1.4, count)):
        along = height / tall  # 0 at the root, 1 at the tip
        centre = root + lean * along**2
        blade = (along <= 1.0) & (np.abs(x - centre) < width * (1.0 - along))
        alpha[blade] = 1.0
        tint[blade] = shade * (0.6 + 0.4 * along[blade])  # darker near the ground
    return to_rgba8(_tint(colour, tint), alpha)
