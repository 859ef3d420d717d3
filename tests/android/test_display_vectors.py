"""What the playback screen shows, against the toolkit: the Java bilinear upscale and display
encoding (android/core Bilinear) bit for bit against ``mnss_kit.ops.resample.upsample_bilinear``
and ``mnss_kit.gpu.reference.encode_unorm8``, and the composed ARGB pixels (Compositor) against
numpy.  Floats travel as IEEE bit patterns."""

from __future__ import annotations

import json

import numpy as np

from mnss_kit.gpu.reference import encode_unorm8
from mnss_kit.ops.resample import upsample_bilinear

# (h, w, channels, scale, jitter): the bundle's x2 jitter, x3, edges of the jitter range, a single row and column
CASES = ((24, 32, 3, 2, (-0.25, -0.25)), (24, 32, 3, 2, (0.25, -0.25)), (9, 7, 3, 3, (1 / 3, -1 / 3)),
         (5, 6, 4, 2, (0.5, -0.5)), (1, 5, 3, 2, (0.0, 0.0)), (6, 1, 3, 4, (-0.375, 0.125)), (16, 16, 3, 2, (0.1234, -0.4321)))


def bits(x: np.ndarray) -> list[int]:
    return np.asarray(x, np.float32).ravel().view(np.int32).tolist()


def argb(rgb: np.ndarray) -> list[int]:
    rgb = rgb.astype(np.int64)
    return (0xFF000000 | rgb[..., 0] << 16 | rgb[..., 1] << 8 | rgb[..., 2]).ravel().tolist()


def make_vectors() -> dict:
    rng = np.random.default_rng(16)
    bilinear = []
    for h, w, c, scale, jitter in CASES:
        # display values a little beyond [0, 1], as a renderer's colour may be, in float16 as the texture holds them
        lr = rng.uniform(-0.05, 1.05, (h, w, c)).astype(np.float16)
        offset = np.float32(jitter)
        hr = upsample_bilinear(lr.astype(np.float32), scale, offset=tuple(offset))
        bilinear.append({"h": h, "w": w, "c": c, "scale": scale, "offset_bits": bits(offset),
                         "lr_half": lr.ravel().view(np.uint16).astype(int).tolist(), "hr_bits": bits(hr),
                         "codes": encode_unorm8(hr[..., :3]).ravel().astype(int).tolist()})
    ties = (np.arange(256, dtype=np.float32) + np.float32(0.5)) / np.float32(255)
    values = np.concatenate([ties, np.nextafter(ties, np.float32(2)), np.nextafter(ties, np.float32(-1)),
                             rng.uniform(-0.5, 1.5, 2000).astype(np.float32),
                             np.float32([0, -0.0, 1, -1e-30, 1 + 1e-7, np.inf, -np.inf])])
    encode = {"v_bits": bits(values), "codes": encode_unorm8(values).astype(int).tolist()}
    composite = []
    for w, h in ((5, 3), (64, 48)):
        left, right = (rng.integers(0, 256, (h, w, 3)).astype(np.uint8) for _ in range(2))
        columns = np.arange(w)[None, :, None]
        splits = [{"x": x, "argb": argb(np.where(columns < min(max(x, 0), w), left, right))} for x in (-1, 0, 1, w // 2, w - 1, w, w + 7)]
        composite.append({"w": w, "h": h, "left": left.ravel().astype(int).tolist(), "right": right.ravel().astype(int).tolist(),
                          "side_by_side": argb(np.concatenate([left, right], axis=1)), "splits": splits})
    return {"bilinear": bilinear, "encode": encode, "composite": composite}


def test_vectors_cover_ties_and_every_code():
    vectors = make_vectors()
    assert set(vectors["encode"]["codes"]) == set(range(256))
    codes = np.concatenate([np.asarray(c["codes"]) for c in vectors["bilinear"]])
    assert codes.min() == 0 and codes.max() == 255  # clamping is exercised


def test_java_bilinear_and_composites_match_the_toolkit(java_core, tmp_path):
    path = tmp_path / "display_vectors.json"
    path.write_text(json.dumps(make_vectors()))
    out = java_core.junit("DisplayVectorsTest", props={"mnss.displayVectors": str(path)})
    assert "OK (3 tests)" in out


def test_java_catches_a_wrong_bilinear_value(java_core, tmp_path):
    vectors = make_vectors()
    vectors["bilinear"][2]["hr_bits"][17] += 1  # one ulp
    path = tmp_path / "bad_vectors.json"
    path.write_text(json.dumps(vectors))
    result = java_core.java("org.junit.runner.JUnitCore", "io.mnsskit.core.DisplayVectorsTest", props={"mnss.displayVectors": str(path)})
    assert result.returncode != 0 and "value 17 is" in result.stdout
