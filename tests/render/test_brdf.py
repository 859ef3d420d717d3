"""Split-sum BRDF LUT and F_beta (mnss_kit.ops.brdf)."""

import numpy as np
import pytest

from mnss_kit.ops import brdf


def test_lut_shape_range_and_cache():
    lut = brdf.brdf_lut()
    assert lut.shape == (brdf.LUT_SIZE, brdf.LUT_SIZE, 2) and lut.dtype == np.float32
    assert lut is brdf.brdf_lut()  # cached
    assert not lut.flags.writeable
    assert np.all(lut >= 0) and np.all(lut.sum(-1) <= 1.0 + 1e-3)  # no energy gain for F0 = 1


def test_lut_known_limits():
    ab = brdf.integrate_brdf(np.array([1.0, 0.05]), np.array([0.05, 0.05]), samples=2048)
    # smooth surface seen head-on: F0 * 1 + 0; at grazing angles Fresnel pushes B up
    assert ab[0, 0] == pytest.approx(1.0, abs=0.02) and ab[0, 1] == pytest.approx(0.0, abs=0.01)
    assert ab[1, 1] > 0.3
    rough = brdf.integrate_brdf(np.array([0.5]), np.array([1.0]), samples=2048)
    assert rough.sum() < 0.8  # rough surfaces lose energy to masking/shadowing


def test_lookup_at_texel_centres_is_exact():
    lut = brdf.brdf_lut()
    n = lut.shape[0]
    centres = (np.arange(n) + 0.5) / n
    r, v = np.meshgrid(centres, centres, indexing="ij")
    np.testing.assert_allclose(brdf.lookup(lut, v, r), lut, atol=1e-6)


def test_fbeta_formula():
    albedo = np.array([[0.8, 0.4, 0.2], [0.9, 0.7, 0.3]], np.float32)
    metallic = np.array([0.0, 1.0])
    rough = np.array([0.5, 0.3])
    nv = np.array([0.7, 0.9])
    ab = brdf.lookup(brdf.brdf_lut(), nv, rough)
    got = brdf.fbeta(albedo, metallic, rough, nv)
    np.testing.assert_allclose(got[0], albedo[0] + 0.04 * ab[0, 0] + ab[0, 1], rtol=1e-5)
    np.testing.assert_allclose(got[1], albedo[1] * ab[1, 0] + ab[1, 1], rtol=1e-5)
