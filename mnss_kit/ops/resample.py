"""Bilinear sampling and resizing with the toolkit's pixel-centre convention.

Coordinates are in pixels with centres at +0.5 (``conventions``); samples
outside the image clamp to the edge texel.  ``upsample_bilinear`` equals
PyTorch's ``F.interpolate(mode="bilinear", align_corners=False)``.
"""

from __future__ import annotations

import numpy as np


def bilinear_sample(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Sample ``(H, W, C)`` float32 ``image`` at pixel coordinates ``x, y`` (any equal shapes).

    Returns ``x.shape + (C,)`` float32.  Weights are computed in float32, as a
    GPU does in highp; the clamp happens on the texel indices, not on the
    coordinates, so an off-screen sample reads the edge texel (clamp-to-edge).
    """
    img = np.asarray(image, dtype=np.float32)
    h, w = img.shape[:2]
    fx = np.asarray(x, dtype=np.float32) - np.float32(0.5)
    fy = np.asarray(y, dtype=np.float32) - np.float32(0.5)
    x0 = np.floor(fx)
    y0 = np.floor(fy)
    ax = (fx - x0)[..., None]  # weight of the right texel, in [0, 1)
    ay = (fy - y0)[..., None]
    x0i = x0.astype(np.int64)
    y0i = y0.astype(np.int64)
    xa, xb = np.clip(x0i, 0, w - 1), np.clip(x0i + 1, 0, w - 1)
    ya, yb = np.clip(y0i, 0, h - 1) * w, np.clip(y0i + 1, 0, h - 1) * w
    flat = img.reshape(h * w, -1)  # one flat gather per tap is much faster than 2-D fancy indexing

    def tap(row: np.ndarray, col: np.ndarray) -> np.ndarray:
        return np.take(flat, row + col, axis=0)

    top = tap(ya, xa) * (1 - ax) + tap(ya, xb) * ax
    bottom = tap(yb, xa) * (1 - ax) + tap(yb, xb) * ax
    return (top * (1 - ay) + bottom * ay).astype(np.float32)


def pixel_grid(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre coordinates ``(x, y)``, each ``(h, w)`` float32."""
    y, x = np.meshgrid(np.arange(h, dtype=np.float32) + 0.5, np.arange(w, dtype=np.float32) + 0.5, indexing="ij")
    return x, y


def upsample_bilinear(image: np.ndarray, scale: int, offset: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """Resize ``(h, w, C)`` to ``(h*s, w*s, C)`` bilinearly.

    ``offset`` is where the LR samples really were, relative to their pixel
    centres, in LR pixels (the jitter): the HR pixel at LR position ``u``
    reads the LR image at ``u - offset``.
    """
    h, w = image.shape[:2]
    x, y = pixel_grid(h * scale, w * scale)
    lx = x / np.float32(scale) - np.float32(offset[0])
    ly = y / np.float32(scale) - np.float32(offset[1])
    return bilinear_sample(image, lx, ly)


def avgpool(image: np.ndarray, scale: int) -> np.ndarray:
    """Mean over each ``s x s`` tile: ``(H, W, C)`` -> ``(H/s, W/s, C)`` float32."""
    h, w, c = image.shape
    tiles = np.asarray(image, dtype=np.float32).reshape(h // scale, scale, w // scale, scale, c)
    return tiles.mean(axis=(1, 3), dtype=np.float32)
