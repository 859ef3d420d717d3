"""Small captures in the formats ``mnss-kit data import`` reads, written from their specs, with the values written.

``write_nss_capture``: an Arm NSS capture (docs of Arm's Neural Graphics Model Gym, spec 1.0.1);
``write_packed_capture``: a packed 8-bit PNG capture (mnss_kit/configs/import/packed8.yaml).
"""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np
from PIL import Image

from mnss_kit.dataset.exr import write_exr

QUANTIZED_HALTON = [((k * 5 + 3) % 8 + 0.5) / 8 - 0.5 for k in range(16)]  # offsets in [-0.5, 0.5), multiples of 1/16


def nss_frame_json(i: int, ratios: dict[str, tuple[int, int]], near: float, far: float, cut: bool, exposure) -> dict:
    jitter = (QUANTIZED_HALTON[i % 16], QUANTIZED_HALTON[(i + 5) % 16])
    frame = {
        "Frame": i, "FovX": 1.2, "FovY": 0.7, "CameraNearPlane": near, "CameraFarPlane": far,
        "ViewProjection": [float(v) for v in np.eye(4).ravel()], "Jitter": {"X": jitter[0], "Y": jitter[1]},
        "NormalizedPerRatioJitter": [{"X": jitter[0] / w, "Y": jitter[1] / h} for w, h in ratios.values()],
        "CameraCut": cut,
    }
    if exposure is not None:
        frame["Exposure"] = exposure
    return frame


def write_nss_capture(root: Path, hr_size=(32, 16), ratios=("2",), frames=5, cut_at=3, near=0.5, far=50.0,
                      reverse_z=False, exposure=None, sequence="0000", seed=0) -> dict:
    """Write one sequence; returns the stored arrays by buffer (``(frames, H, W, C)`` float32) and the JSON."""
    rng = np.random.default_rng(seed)
    hw, hh = hr_size
    sizes = {r: (round(hw / float(r.replace("_", "."))), round(hh / float(r.replace("_", ".")))) for r in ratios}
    stored = {"ground_truth": [], "motion_gt": []} | {f"x{r}/{b}": [] for r in ratios for b in ("color", "depth", "motion")}

    def put(key: str, i: int, image: np.ndarray, half: bool, channels: tuple[str, ...]) -> None:
        write_exr(root / key / sequence / f"{i:04d}.exr", image, half=half, channels=channels)
        stored[key].append(image.astype(np.float16 if half else np.float32).astype(np.float32))

    for i in range(frames):
        put("ground_truth", i, rng.uniform(0, 6, (hh, hw, 4)), True, ("R", "G", "B", "A"))
        put("motion_gt", i, rng.uniform(-0.05, 0.05, (hh, hw, 2)), True, ("R", "G"))
        for r, (w, h) in sizes.items():
            put(f"x{r}/color", i, rng.uniform(0, 6, (h, w, 4)), True, ("R", "G", "B", "A"))
            put(f"x{r}/depth", i, rng.uniform(0.05, 0.99, (h, w, 1)), False, ("R",))
            put(f"x{r}/motion", i, rng.uniform(-0.05, 0.05, (h, w, 2)), True, ("R", "G"))
    exposures = exposure if isinstance(exposure, list) else [exposure] * frames
    meta = {
        "Version": "1.0.1", "EmulatedFramerate": 60, "TargetResolution": {"X": hw, "Y": hh},
        "Samples": {"Sequence": "TiledHalton", "Count": 16, "Quantized": True}, "ReverseZ": reverse_z,
        "UpscalingRatiosIndices": {f"x{r}_index": k for k, r in enumerate(ratios)},
        "GTColorSpace": "Linear",
        "Frames": [nss_frame_json(i, sizes, near, far, i == cut_at, exposures[i]) for i in range(frames)],
    }
    (root / f"{sequence}.json").write_text(json.dumps(meta))
    return {k: np.stack(v) for k, v in stored.items()} | {"json": meta, "sizes": sizes}


def write_png(path: Path, image: np.ndarray, bits: int = 8) -> None:
    """``(H, W, C)`` integers as a PNG; 16-bit colour through a minimal writer (Pillow writes 8-bit colour only)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if bits == 8 or image.shape[2] == 1:
        data = image[..., 0] if image.shape[2] == 1 else image
        Image.fromarray(data.astype(np.uint8 if bits == 8 else np.uint16)).save(path)
        return
    h, w, c = image.shape
    rows = [bytes([f]) + _filter(image[y].astype(">u2").tobytes(), image[y - 1].astype(">u2").tobytes() if y else None, f, 2 * c)
            for y, f in zip(range(h), [0, 1, 2, 3, 4] * h)]
    header = struct.pack(">IIBBBBB", w, h, 16, {2: 4, 3: 2, 4: 6}[c], 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", header) + _chunk(b"IDAT", zlib.compress(b"".join(rows)))
                     + _chunk(b"IEND", b""))


def _filter(row: bytes, up: bytes | None, kind: int, bpp: int) -> bytes:
    """PNG filter ``kind`` of one row (every filter type, to test the reader's unfiltering)."""
    x = np.frombuffer(row, np.uint8).astype(np.int32)
    b = np.zeros_like(x) if up is None else np.frombuffer(up, np.uint8).astype(np.int32)
    a = np.concatenate([np.zeros(bpp, np.int32), x[:-bpp]])
    c = np.concatenate([np.zeros(bpp, np.int32), b[:-bpp]])
    if kind == 0:
        pred = np.zeros_like(x)
    elif kind == 1:
        pred = a
    elif kind == 2:
        pred = b
    elif kind == 3:
        pred = (a + b) // 2
    else:
        p = a + b - c
        pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
        pred = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
    return ((x - pred) % 256).astype(np.uint8).tobytes()


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def pack_pair(values: np.ndarray) -> np.ndarray:
    """``(..., 2)`` numbers in [0, 1) -> ``(..., 2)`` uint8 pairs (hi, lo), value ~ hi/255 + lo/255^2."""
    scaled = np.round(values * 255.0 * 255.0).astype(np.int64)
    return np.stack([scaled // 255, scaled % 255], axis=-1).astype(np.uint8)


def write_packed_capture(root: Path, lr_size=(16, 12), scale=2, frames=4, cut_at=2, seed=0) -> dict:
    """One sequence folder ``root/seq0`` in the packed 8-bit layout; returns the motion in pixels and the stored images."""
    rng = np.random.default_rng(seed)
    lw, lh = lr_size
    seq = root / "seq0"
    out = {"motion_px": [], "color": [], "depth": [], "reference": []}
    for t in range(frames):
        colour = rng.integers(0, 256, (lh, lw, 3), dtype=np.uint8)
        depth = rng.integers(1, 256, (lh, lw, 1), dtype=np.uint8)
        reference = rng.integers(0, 256, (lh * scale, lw * scale, 3), dtype=np.uint8)
        uv = rng.uniform(0.3, 0.7, (lh, lw, 2))
        packed = pack_pair(uv)  # (h, w, 2 values, 2 bytes)
        rgba = packed.reshape(lh, lw, 4)  # R, G = u; B, A = v
        stored_uv = rgba[..., 0::2] / 255.0 + rgba[..., 1::2] / 255.0**2
        # the layout's definition: motion = (2u - 1) w, -(2v - 1) h, previous -> current; canonical is current -> previous
        out["motion_px"].append(-np.stack([(2 * stored_uv[..., 0] - 1) * lw, -(2 * stored_uv[..., 1] - 1) * lh], -1))
        write_png(seq / f"lr/color/{t:04d}.png", colour)
        write_png(seq / f"lr/depth/{t:04d}.png", depth)
        write_png(seq / f"lr/motion/{t:04d}.png", rgba)
        write_png(seq / f"hr/color/{t:04d}.png", reference)
        out["color"].append(colour)
        out["depth"].append(depth)
        out["reference"].append(reference)
    jitter = np.array([[QUANTIZED_HALTON[t % 16], QUANTIZED_HALTON[(t + 3) % 16]] for t in range(frames)])
    np.savetxt(seq / "jitter.txt", jitter)
    (seq / "cuts.txt").write_text(f"{cut_at}\n")
    return {k: np.stack(v) for k, v in out.items()} | {"jitter": jitter, "seq": seq}
