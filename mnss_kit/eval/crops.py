"""Side-by-side PNG crops: reference, then every method, each labelled; below each method its error map.

For a few frames per sequence two regions are cut out: the one where the
first method (the model, when there is one) has its highest mean error, and
a fixed centre crop.  Crops are enlarged with nearest-neighbour filtering so
single pixels stay visible.  The error map shows the mean absolute error over the channels,
black at 0 through red and yellow to white at :data:`ERROR_FULL_SCALE` and above.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..fileio import atomic_write_bytes
from ..metrics.psnr import psnr

CROP = 64  # HR pixels per side (smaller frames use their short side)
PANEL = 192  # minimum displayed panel size in screen pixels
LABEL_HEIGHT = 16
ERROR_FULL_SCALE = 0.25  # mean absolute error (display values) drawn white


def crop_frame_indices(n: int, cuts: list[int]) -> set[int]:
    """Frames that get crops: the middle, the last, and the frame after the first cut."""
    picks = {n // 2, n - 1}
    if cuts and cuts[0] + 1 < n:
        picks.add(cuts[0] + 1)
    return picks


def worst_window(error: np.ndarray, size: int) -> tuple[int, int]:
    """Top-left ``(y, x)`` of the ``size x size`` window with the largest summed ``error`` (H, W)."""
    integral = np.pad(np.cumsum(np.cumsum(error.astype(np.float64), axis=0), axis=1), ((1, 0), (1, 0)))
    sums = integral[size:, size:] - integral[:-size, size:] - integral[size:, :-size] + integral[:-size, :-size]
    y, x = np.unravel_index(int(np.argmax(sums)), sums.shape)
    return int(y), int(x)


def write_crops(out_dir: Path, seq: str, frame: int, reference: np.ndarray, outputs: dict[str, np.ndarray]) -> list[Path]:
    """Write ``{seq}_{frame:05d}_{worst,centre}.png`` under ``out_dir``; images are ``(H, W, 3)`` in [0, 1]."""
    h, w = reference.shape[:2]
    size = min(CROP, h, w)
    focus = next(iter(outputs))
    error = np.abs(outputs[focus] - reference).mean(axis=-1)
    regions = {"worst": worst_window(error, size), "centre": ((h - size) // 2, (w - size) // 2)}
    paths = []
    for kind, (y, x) in regions.items():
        panels = [("reference", reference[y : y + size, x : x + size], None)]
        for name, image in outputs.items():
            tile = image[y : y + size, x : x + size]
            panels.append((name, tile, psnr(tile, panels[0][1])))
        title = f"{seq} frame {frame} ({kind} {focus} crop at x={x} y={y})"
        path = Path(out_dir) / f"{seq}_{frame:05d}_{kind}.png"
        atomic_write_bytes(path, _render(panels, title))
        paths.append(path)
    return paths


def _render(panels: list[tuple[str, np.ndarray, float | None]], title: str) -> bytes:
    """A row of labelled panels as PNG bytes."""
    from PIL import Image, ImageDraw

    size = panels[0][1].shape[0]
    zoom = max(1, -(-PANEL // size))
    side = size * zoom
    gap = 4
    width = len(panels) * (side + gap) + gap
    canvas = Image.new("RGB", (width, 2 * side + 2 * LABEL_HEIGHT + 2 * gap), (32, 32, 32))
    draw = ImageDraw.Draw(canvas)
    draw.text((gap, 2), title, fill=(230, 230, 230))
    draw.text((gap, 2 * LABEL_HEIGHT + side + gap + 2), f"error maps:\n|error| {ERROR_FULL_SCALE}+ is white", fill=(200, 200, 200))
    for i, (name, tile, value) in enumerate(panels):
        pixels = np.round(np.clip(tile, 0.0, 1.0) * 255.0).astype(np.uint8)
        img = Image.fromarray(pixels, "RGB").resize((side, side), Image.NEAREST)
        left = gap + i * (side + gap)
        canvas.paste(img, (left, 2 * LABEL_HEIGHT))
        label = name if value is None else f"{name}  {value:.2f} dB"
        draw.text((left, LABEL_HEIGHT + 2), label, fill=(255, 255, 255))
        if i > 0:
            heat = error_heat(np.abs(tile - panels[0][1]).mean(axis=-1))
            canvas.paste(Image.fromarray(heat, "RGB").resize((side, side), Image.NEAREST), (left, 2 * LABEL_HEIGHT + side + gap))
    buf = io.BytesIO()
    canvas.save(buf, format="PNG")
    return buf.getvalue()


def error_heat(error: np.ndarray) -> np.ndarray:
    """``(H, W)`` absolute error -> ``(H, W, 3)`` uint8: black, red, yellow, white at ERROR_FULL_SCALE."""
    e = np.clip(error / ERROR_FULL_SCALE, 0.0, 1.0)[..., None] * 3.0
    rgb = np.clip(e - np.array([0.0, 1.0, 2.0]), 0.0, 1.0)
    return np.round(rgb * 255.0).astype(np.uint8)
