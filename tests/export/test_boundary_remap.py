"""The texture remaps of a boundary tensor, checked over every int8 code against ``real = s * (q - z)``
and GL ES normalized conversion (SNORM8: v = q / 127, clamped at -1; UNORM8: v = u / 255)."""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.export.boundary import boundary_entry, real_from_snorm8, real_from_unorm8, texture_remaps

CODES = np.arange(-128, 128)
PARAMS = [(1 / 255, -128), (0.0123, 5), (0.5, 127), (2.0 ** -7, 0)]


def real(q, scale, zero_point):
    return np.float64(np.float32(scale)) * (q - zero_point)


@pytest.mark.parametrize("scale, zero_point", PARAMS)
def test_snorm8_maps_every_writable_code_and_loses_minus_128(scale, zero_point):
    stored = np.maximum(CODES, -127)  # a float -> SNORM8 conversion clamps to -1 = -127 / 127
    texel = stored / 127.0
    got = real_from_snorm8(texel, scale, zero_point)
    writable = CODES >= -127
    np.testing.assert_allclose(got[writable], real(CODES[writable], scale, zero_point), rtol=1e-12, atol=1e-12)
    remap = texture_remaps(scale, zero_point)["snorm8"]
    assert not remap["exact"] and remap["unreachable_code"] == -128
    assert got[0] == pytest.approx(real(-127, scale, zero_point))  # -128 reads back one step up
    back = remap["texel_from_real"]
    np.testing.assert_allclose(np.rint((real(CODES[writable], scale, zero_point) * back["multiply"] + back["add"]) * 127), CODES[writable])


@pytest.mark.parametrize("scale, zero_point", PARAMS)
def test_unorm8_bytes_are_the_int8_codes(scale, zero_point):
    byte = CODES.astype(np.int8).view(np.uint8).astype(np.float64)  # two's complement byte of each code
    got = real_from_unorm8(byte / 255.0, scale, zero_point)
    np.testing.assert_allclose(got, real(CODES, scale, zero_point), rtol=1e-12, atol=1e-12)
    assert texture_remaps(scale, zero_point)["unorm8"]["exact"]


def test_rgba8i_and_entry_fields():
    entry = boundary_entry("npu_input", "image", "gpu->npu", [1, 4, 6, 3], "int8", 1 / 255, -128, "npu_input")
    m = entry["texture_remap"]["rgba8i"]["real_from_code"]
    assert CODES * m["multiply"] + m["add"] == pytest.approx(real(CODES, 1 / 255, -128))
    assert entry["bytes"] == 72 and entry["buffer"]["words"] == 18
    assert entry["real_range"] == [0.0, pytest.approx(1.0)]
    with pytest.raises(ValueError):
        boundary_entry("npu_input", "image", "gpu->npu", [1, 4, 6, 3], "int16", 1.0, 0, "npu_input")
