"""Read one image file of a capture as stored: PNG (8 or 16 bits), OpenEXR or NumPy ``.npy``.

``read_image`` returns ``(H, W, C)`` in the file's own type: uint8, uint16 or float32; the
importer's decode rules give the values their meaning.  Pillow reads 8-bit PNG and 16-bit grey
PNG exactly but keeps only 8 bits of 16-bit colour PNG, so those are decoded here.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from ...errors import UserError
from .. import exr

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PNG_CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}  # colour type -> channels (3, palette, is read by Pillow)


def read_image(path: Path) -> np.ndarray:
    if not path.is_file():
        raise UserError(f"missing file: {path}")
    exr.refuse_lfs_pointer(path)
    suffix = path.suffix.lower()
    if suffix == ".png":
        return _read_png(path)
    if suffix == ".exr":
        return exr.read_exr(path)
    if suffix == ".npy":
        return _read_npy(path)
    raise UserError(f"{path}: unknown image type '{suffix}' (png, exr or npy)")


def _read_npy(path: Path) -> np.ndarray:
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError) as e:
        raise UserError(f"cannot read {path}: not a valid .npy file ({e})") from None
    if array.ndim == 2:
        array = array[..., None]
    if array.ndim != 3 or array.dtype.kind not in "uif":
        raise UserError(f"{path}: expected an (H, W) or (H, W, C) numeric array, got {array.dtype} {array.shape}")
    if array.dtype.kind == "f":
        return array.astype(np.float32)
    return array if array.dtype in (np.uint8, np.uint16) else array.astype(np.float32)


def _read_png(path: Path) -> np.ndarray:
    data = path.read_bytes()
    if not data.startswith(PNG_SIGNATURE) or len(data) < 33:
        raise UserError(f"cannot read {path}: not a PNG file")
    width, height, bits, colour_type, _, _, interlace = struct.unpack(">IIBBBBB", data[16:29])
    if bits == 16 and colour_type in PNG_CHANNELS:
        return _decode_png16(path, data, width, height, PNG_CHANNELS[colour_type], interlace)
    if bits not in (8, 16) and colour_type != 3:
        raise UserError(f"{path}: {bits}-bit PNG; only 8- and 16-bit PNG are read")
    from PIL import Image

    try:
        with Image.open(path) as im:
            if im.mode == "P":
                im = im.convert("RGBA" if "transparency" in im.info else "RGB")
            array = np.asarray(im)
    except (OSError, SyntaxError, ValueError) as e:
        raise UserError(f"cannot read {path}: corrupt PNG ({e})") from None
    return array[..., None] if array.ndim == 2 else array


def _decode_png16(path: Path, data: bytes, width: int, height: int, channels: int, interlace: int) -> np.ndarray:
    """``(H, W, C)`` uint16 of a non-interlaced 16-bit PNG (filters of the PNG spec, section 9)."""
    if interlace:
        raise UserError(f"{path}: interlaced 16-bit PNG is not read (save it without interlacing)")
    try:
        raw = zlib.decompress(b"".join(_chunks(data, b"IDAT")))
    except zlib.error as e:
        raise UserError(f"cannot read {path}: corrupt PNG data ({e})") from None
    bpp, stride = 2 * channels, 2 * channels * width
    if len(raw) != height * (stride + 1):
        raise UserError(f"cannot read {path}: truncated PNG data")
    rows = np.frombuffer(raw, np.uint8).reshape(height, stride + 1)
    out = np.zeros((height, stride), np.uint8)
    previous = np.zeros(stride, np.uint8)
    for y in range(height):
        out[y] = _unfilter(rows[y, 0], rows[y, 1:], previous, bpp, path)
        previous = out[y]
    return out.view(">u2").reshape(height, width, channels).astype(np.uint16)


def _chunks(data: bytes, kind: bytes):
    pos = len(PNG_SIGNATURE)
    while pos + 8 <= len(data):
        length, name = struct.unpack(">I4s", data[pos : pos + 8])
        if name == kind:
            yield data[pos + 8 : pos + 8 + length]
        pos += 12 + length


def _unfilter(kind: int, row: np.ndarray, up: np.ndarray, bpp: int, path: Path) -> np.ndarray:
    if kind == 0:
        return row
    if kind == 2:
        return row + up  # uint8 arithmetic wraps modulo 256, as the spec wants
    if kind == 1:  # Sub: a running sum per byte lane, modulo 256
        return np.cumsum(row.reshape(-1, bpp), axis=0, dtype=np.uint8).reshape(-1)
    if kind not in (3, 4):
        raise UserError(f"cannot read {path}: unknown PNG filter type {kind}")
    out = np.zeros_like(row)
    a = np.zeros(bpp, np.int32)  # the pixel to the left; c: the one above it
    c = np.zeros(bpp, np.int32)
    for x in range(0, len(row), bpp):
        b = up[x : x + bpp].astype(np.int32)
        if kind == 3:
            predictor = (a + b) // 2
        else:  # Paeth
            p = a + b - c
            pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
            predictor = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
        a = (row[x : x + bpp].astype(np.int32) + predictor) % 256
        out[x : x + bpp] = a
        c = b
    return out
