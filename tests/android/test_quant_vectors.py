"""The Java int8 quantize / dequantize / pack against golden vectors from ``mnss_kit.ops.int8.quantize``.

Vectors per profile and scale: values on and next to rounding ties (where the profiles differ),
random values over and beyond the representable range, signed zeros, subnormals, huge values
and infinities (NaN has no defined int8 value in numpy; the Java core maps it to the zero point,
as quant.glsl does, and its unit test covers that).  The quantization parameters are the
``u_q_*`` uniforms a bundle carries (``mnss_kit.gpu.passes.quantize_uniforms``), so the Java
side reads them in the form the app gets them.
"""

from __future__ import annotations

import json

import numpy as np

from mnss_kit.gpu.passes import quantize_uniforms
from mnss_kit.ops.int8.quantize import dequantize, quantize
from mnss_kit.ops.runtimes import RUNTIMES

PROFILES = tuple(RUNTIMES)
# (scale, zero point): the usual image tensors, the fixed LOGISTIC output, and odd ones.
QPARAMS = ((1 / 255, -128), (1 / 256, -128), (0.0123, -3), (0.00731, 17), (0.5, 0), (2.3e-4, 127))


def bits(x: np.ndarray) -> list[int]:
    return np.asarray(x, np.float32).view(np.int32).tolist()


def probe_values(scale: np.float32, zero_point: int, rng: np.random.Generator) -> np.ndarray:
    """float32 values that exercise ties, neighbours, saturation and special values."""
    k = np.arange(-300, 300, dtype=np.float64) - zero_point
    ties = ((k + 0.5) * np.float64(scale)).astype(np.float32)
    up, down = np.nextafter(ties, np.float32(np.inf)), np.nextafter(ties, np.float32(-np.inf))
    grid = (k * np.float64(scale)).astype(np.float32)
    span = float(scale) * 300
    uniform = rng.uniform(-span, span, 1000).astype(np.float32)
    special = np.array([0.0, -0.0, 1e-45, -1e-45, 1e-38, 3e38, -3e38, np.inf, -np.inf, 1.0, -1.0], np.float32)
    return np.concatenate([ties, up, down, grid, uniform, special])


def make_vectors() -> dict:
    rng = np.random.default_rng(7)
    out = {"quantize": [], "dequantize": [], "pack": []}
    for scale, zp in QPARAMS:
        s = np.float32(scale)
        x = probe_values(s, zp, rng)
        for profile in PROFILES:
            u = quantize_uniforms(s, zp, profile)
            with np.errstate(over="ignore"):  # 3e38 / scale overflows to inf, which saturates
                q = quantize(x, s, zp, "int8", profile)
            out["quantize"].append({
                "profile": profile,
                "u_q_scale_bits": bits([u["u_q_scale"]])[0],
                "u_q_reciprocal_bits": bits([u["u_q_reciprocal"]])[0],
                "u_q_use_reciprocal": u["u_q_use_reciprocal"],
                "u_q_rounding": u["u_q_rounding"],
                "u_q_zero_point": u["u_q_zero_point"],
                "x_bits": bits(x),
                "q": q.astype(int).tolist(),
            })
        codes = np.arange(-128, 128)
        out["dequantize"].append({"scale_bits": bits([s])[0], "zero_point": zp, "q": codes.tolist(),
                                  "r_bits": bits(dequantize(codes, s, zp))})
    for n in (1, 3, 4, 5, 96, 1001):
        values = rng.integers(-128, 128, n).astype(np.int8)
        padded = np.concatenate([values, np.zeros(-n % 4, np.int8)])
        words = padded.view("<u4")
        out["pack"].append({"values": values.astype(int).tolist(), "words": words.astype(np.int64).tolist()})
    return out


def test_profiles_disagree_on_the_vectors():
    """The vectors must be able to tell the profiles apart, or matching them proves little."""
    vectors = make_vectors()["quantize"]
    by_params: dict[tuple, list] = {}
    for case in vectors:
        by_params.setdefault((case["u_q_scale_bits"], case["u_q_zero_point"]), []).append(case["q"])
    differing = sum(any(q != qs[0] for q in qs[1:]) for qs in by_params.values())
    assert differing >= len(QPARAMS) - 1


def test_java_matches_the_toolkit_bit_for_bit(java_core, tmp_path):
    path = tmp_path / "quant_vectors.json"
    vectors = make_vectors()
    path.write_text(json.dumps(vectors))
    out = java_core.junit("QuantVectorsTest", props={"mnss.quantVectors": str(path)})
    assert "OK (3 tests)" in out
    assert sum(len(c["q"]) for c in vectors["quantize"]) > 50_000


def test_java_catches_a_wrong_vector(java_core, tmp_path):
    """Flip one expected code: the Java test must fail and name the value."""
    vectors = make_vectors()
    case = vectors["quantize"][3]
    case["q"][10] = case["q"][10] + (1 if case["q"][10] < 127 else -1)
    path = tmp_path / "bad_vectors.json"
    path.write_text(json.dumps(vectors))
    result = java_core.java("org.junit.runner.JUnitCore", "io.mnsskit.core.QuantVectorsTest", props={"mnss.quantVectors": str(path)})
    assert result.returncode != 0
    assert "quantizes to" in result.stdout and case["profile"] in result.stdout
