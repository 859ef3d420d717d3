"""Helpers shared by the glTF and OBJ importers: fill-in warnings, normals, images, alpha."""

from __future__ import annotations

import io
import logging
from collections import defaultdict
from pathlib import Path

import numpy as np

from mnss_kit.errors import UserError

log = logging.getLogger("mnss_kit.render.importers")

_LISTED_ITEMS = 5  # a warning names at most this many items, then says how many more


class FillIns:
    """Collects what an importer filled in for one file and logs one warning per kind of fill-in.

    ``note("computed smooth normals", "mesh 'Cube'")`` twice and ``emit()`` once gives a single
    ``logging.warning`` naming the file, what was filled in and where.
    """

    def __init__(self, source: Path):
        self.source = source
        self._items: dict[str, list[str]] = defaultdict(list)

    def note(self, what: str, item: str) -> None:
        if item not in self._items[what]:
            self._items[what].append(item)

    def emit(self) -> None:
        for what, items in self._items.items():
            listed = ", ".join(items[:_LISTED_ITEMS])
            more = f" and {len(items) - _LISTED_ITEMS} more" if len(items) > _LISTED_ITEMS else ""
            log.warning("%s: %s: %s%s", self.source, what, listed, more)
        self._items.clear()


def normalize_rows(v: np.ndarray, fallback=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Unit-length rows of (N, 3) float32; zero-length rows become ``fallback``."""
    v = np.asarray(v, dtype=np.float32)
    length = np.linalg.norm(v, axis=1, keepdims=True)
    ok = length[:, 0] > 1e-20
    out = np.empty_like(v)
    out[ok] = v[ok] / length[ok]
    out[~ok] = fallback
    return out


def smooth_normals(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted smooth vertex normals, (V, 3) float32.

    positions: (V, 3) float; triangles: (T, 3) integer, counter-clockwise front faces.  Vertices
    at exactly the same position share one normal (so UV seams do not show as creases); a vertex
    that touches only degenerate triangles gets +z.
    """
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    _, welded = np.unique(positions, axis=0, return_inverse=True)
    welded = welded.reshape(-1)
    p0, p1, p2 = (positions[triangles[:, k]] for k in range(3))
    face = np.cross(p1 - p0, p2 - p0)  # length = twice the area: the area weighting
    accumulated = np.zeros((int(welded.max(initial=-1)) + 1, 3))
    for k in range(3):
        np.add.at(accumulated, welded[triangles[:, k]], face)
    return normalize_rows(accumulated[welded])


def decode_image(data: bytes, what: str) -> np.ndarray:
    """Encoded image bytes (PNG, JPEG, ...) -> (H, W, 3|4) uint8, channels as stored (sRGB).

    Alpha is kept (channel 3) only when the image has one.  Raises UserError naming ``what``
    when the bytes are not a readable image.
    """
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(data)) as image:
            if image.mode.startswith("I"):  # 16-bit grey; PIL's own conversion would clip at 255
                grey = np.clip(np.asarray(image, dtype=np.float64) / 257.0, 0.0, 255.0).round().astype(np.uint8)
                return np.repeat(grey[..., None], 3, axis=2)
            has_alpha = image.mode in ("RGBA", "LA", "PA") or "transparency" in image.info
            return np.asarray(image.convert("RGBA" if has_alpha else "RGB"), dtype=np.uint8).copy()
    except (UnidentifiedImageError, OSError, ValueError) as error:
        raise UserError(f"{what}: cannot decode image ({error})") from None


def bake_alpha(texture: np.ndarray | None, alpha: float) -> np.ndarray:
    """Multiply a constant alpha into a texture's alpha channel, (H, W, 4) uint8.

    ``Material`` has no scalar alpha, so a material-wide alpha is carried by the base colour
    texture; without a texture a 1x1 white texture (sRGB 255 = linear 1.0) carries it.
    """
    if texture is None:
        texture = np.full((1, 1, 3), 255, dtype=np.uint8)
    if texture.shape[2] == 3:
        texture = np.concatenate([texture, np.full(texture.shape[:2] + (1,), 255, np.uint8)], axis=2)
    out = texture.copy()
    out[..., 3] = np.round(out[..., 3].astype(np.float32) * np.float32(alpha)).astype(np.uint8)
    return out
