"""Motion vectors as engines write them: packed, dilated, wrong on some objects, absent on others.

Every function takes and returns canonical LR motion (``(h, w, 2)`` float32 pixels, +y down,
pointing to the previous frame; ``mnss_kit.ops.conventions``), so ``data variant`` (files) and
the training augmentations (windows) share one definition of each:

    pack8        each component in UV units mapped to u = 0.5 + m_uv / 2 (a velocity range of one
                 screen either way, clamped) and stored in two 8-bit channels, u = R/255 + G/255^2
                 (:func:`pack_motion8` / :func:`unpack_motion8`): a step of 2 / 255^2 screens
    half         each component in UV units rounded to a 16-bit float (an RG16F velocity target)
    dilate       each pixel takes the motion of the nearest-depth pixel of its 3x3 neighbourhood
                 (clamped at the border; the centre wins ties, then row-major order): the
                 convention of Unreal's velocity resolve and of FSR2's input
    rigid        on the moving objects of "rigid" screen cells, every pixel of an object takes the
                 object's median motion: one transform for the whole object, as an engine gives a
                 skinned or vertex-animated mesh whose velocity comes from its root alone
    absent       on the moving objects of "absent" screen cells, motion 0: what a velocity target
                 cleared to zero holds where particles, transparents and objects outside the
                 velocity pass drew

An object is a 4-connected region whose motion differs from the camera's own (computed from depth
and the camera matrices) by more than :data:`OBJECT_MOTION_PX`.  Which objects are touched is
drawn once per sequence on a :data:`CELL_GRID` grid of screen cells (:func:`object_cells`): an
object follows the cell of its centre, so it keeps its kind while it stays in that cell, and
``rigid`` and ``absent`` never pick the same object.
"""

from __future__ import annotations

import zlib

import numpy as np

OBJECT_MOTION_PX = 0.25  # LR pixels of motion beyond the camera's that make a pixel part of an object
CELL_GRID = 4  # the screen is CELL_GRID x CELL_GRID cells for the per-sequence object draw
CELL_SHARES = {"exact": 0.25, "rigid": 0.5, "absent": 0.25}  # chance of each kind per cell
PACK8_LEVELS = 255 * 255  # u = R/255 + G/255^2 takes PACK8_LEVELS + 1 values in [0, 1]


def pack_motion8(motion_uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """UV motion (any shape) -> the two uint8 channels ``(R, G)`` with u = R/255 + G/255^2."""
    u = np.clip(0.5 + 0.5 * np.asarray(motion_uv, np.float64), 0.0, 1.0)
    q = np.round(u * PACK8_LEVELS).astype(np.int64)  # 0 .. 255 * 255
    return (q // 255).astype(np.uint8), (q % 255).astype(np.uint8)


def unpack_motion8(r: np.ndarray, g: np.ndarray) -> np.ndarray:
    """The two uint8 channels -> UV motion (float64), the inverse of :func:`pack_motion8`."""
    u = r.astype(np.float64) / 255.0 + g.astype(np.float64) / (255.0 * 255.0)
    return 2.0 * u - 1.0


def packed8(motion: np.ndarray) -> np.ndarray:
    """Canonical motion after a round trip through the 8-bit pair packing."""
    size = np.array(motion.shape[1::-1], np.float64)  # (w, h)
    return (unpack_motion8(*pack_motion8(motion / size)) * size).astype(np.float32)


HALF_MAX = float(np.finfo(np.float16).max)


def half_float(motion: np.ndarray) -> np.ndarray:
    """Canonical motion after a round trip through 16-bit floats in UV units, saturated at the
    format's largest value: a cast past it would give inf, which no reader should have to mend."""
    size = np.array(motion.shape[1::-1], np.float64)
    uv = np.clip(motion / size, -HALF_MAX, HALF_MAX)
    return (uv.astype(np.float16).astype(np.float64) * size).astype(np.float32)


def dilated(motion: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Each pixel's motion replaced by that of the nearest (smallest canonical ``depth``, ``(h, w)``
    or ``(h, w, 1)``) pixel of its 3x3 neighbourhood; the centre wins ties, then row-major order."""
    depth = depth.reshape(depth.shape[0], depth.shape[1])
    h, w = depth.shape
    ys, xs = np.arange(h)[:, None], np.arange(w)[None, :]
    best_y, best_x = np.broadcast_to(ys, (h, w)).copy(), np.broadcast_to(xs, (h, w)).copy()
    best = depth.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy == 0 and dx == 0:
                continue
            ny, nx = np.clip(ys + dy, 0, h - 1), np.clip(xs + dx, 0, w - 1)
            d = depth[ny, nx]
            nearer = d < best  # strict: the centre and earlier neighbours keep ties
            best = np.where(nearer, d, best)
            best_y = np.where(nearer, np.broadcast_to(ny, (h, w)), best_y)
            best_x = np.where(nearer, np.broadcast_to(nx, (h, w)), best_x)
    return motion[best_y, best_x].astype(np.float32)


def object_cells(sequence_name: str) -> np.ndarray:
    """``(CELL_GRID, CELL_GRID)`` array of kinds (``"exact"``, ``"rigid"``, ``"absent"``), drawn once
    per sequence from its name, so every transform and every run picks the same objects."""
    rng = np.random.default_rng(zlib.crc32(f"{sequence_name}/objects".encode()))
    kinds = list(CELL_SHARES)
    return rng.choice(np.array(kinds), size=(CELL_GRID, CELL_GRID), p=list(CELL_SHARES.values()))


def moving_objects(motion: np.ndarray, camera: np.ndarray) -> tuple[np.ndarray, int]:
    """``(labels, count)``: the 4-connected regions whose motion differs from the ``camera``-only
    motion by more than :data:`OBJECT_MOTION_PX` (labels 1..count, 0 elsewhere)."""
    from scipy import ndimage

    moving = np.linalg.norm(motion - camera, axis=-1) > OBJECT_MOTION_PX
    labels, count = ndimage.label(moving)
    return labels, int(count)


def objects_of_kind(labels: np.ndarray, count: int, cells: np.ndarray, kind: str) -> list[np.ndarray]:
    """Boolean masks of the labelled objects whose centre lies in a cell of ``kind``."""
    h, w = labels.shape
    masks = []
    for label in range(1, count + 1):
        mask = labels == label
        ys, xs = np.nonzero(mask)
        cy = min(int(ys.mean() * CELL_GRID / h), CELL_GRID - 1)
        cx = min(int(xs.mean() * CELL_GRID / w), CELL_GRID - 1)
        if cells[cy, cx] == kind:
            masks.append(mask)
    return masks


def rigid(motion: np.ndarray, objects: list[np.ndarray]) -> np.ndarray:
    """``motion`` with every pixel of each object mask set to the object's median motion."""
    out = motion.copy()
    for mask in objects:
        out[mask] = np.median(motion[mask], axis=0)
    return out.astype(np.float32)


def absent(motion: np.ndarray, objects: list[np.ndarray]) -> np.ndarray:
    """``motion`` with every pixel of each object mask set to 0."""
    out = motion.copy()
    for mask in objects:
        out[mask] = 0.0
    return out.astype(np.float32)
