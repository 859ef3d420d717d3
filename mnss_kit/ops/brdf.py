"""Split-sum pre-integrated BRDF (GGX + Smith) and the F_beta demodulation factor.

``brdf_lut`` integrates, for view angle ``N.V`` and perceptual roughness ``r``
(GGX ``alpha = r^2``), the scale ``A`` and bias ``B`` of the specular
directional albedo under uniform white light::

    int f_spec(l, v) (n.l) dl  ==  F0 * A + B      (Schlick Fresnel)

The renderer samples the same table as a texture and FuseSR uses it to
demodulate.  ``fbeta`` is the pre-integrated BRDF of the toolkit's material
model (Lambert diffuse + GGX specular, metallic workflow)::

    diffuse  = albedo * (1 - metallic)
    F0       = 0.04 * (1 - metallic) + albedo * metallic
    F_beta   = diffuse + F0 * A(N.V, r) + B(N.V, r)          (per RGB channel)

The table is computed once per process (``functools.lru_cache``); it is small
(default 32 x 32) and takes well under a second.
"""

from __future__ import annotations

import functools

import numpy as np

LUT_SIZE = 32
LUT_SAMPLES = 512
DIELECTRIC_F0 = 0.04


def hammersley(n: int) -> np.ndarray:
    """``(n, 2)`` float64 Hammersley points in [0, 1)^2 (i/n, base-2 radical inverse of i)."""
    i = np.arange(n, dtype=np.uint32)
    bits = i.copy()
    bits = ((bits << 16) | (bits >> 16)) & 0xFFFFFFFF
    bits = ((bits & 0x55555555) << 1) | ((bits & 0xAAAAAAAA) >> 1)
    bits = ((bits & 0x33333333) << 2) | ((bits & 0xCCCCCCCC) >> 2)
    bits = ((bits & 0x0F0F0F0F) << 4) | ((bits & 0xF0F0F0F0) >> 4)
    bits = ((bits & 0x00FF00FF) << 8) | ((bits & 0xFF00FF00) >> 8)
    return np.stack([i / n, bits.astype(np.float64) / 2.0**32], axis=1)


def integrate_brdf(n_dot_v: np.ndarray, roughness: np.ndarray, samples: int = LUT_SAMPLES) -> np.ndarray:
    """``(..., 2)`` float64 ``(A, B)`` for arrays of ``N.V`` in (0, 1] and perceptual roughness.

    GGX importance sampling of the half vector in tangent space (N = +z), Smith
    height-uncorrelated G with the IBL ``k = alpha / 2``; the usual split-sum estimator
    ``G * V.H / (N.H * N.V)`` weighted by ``(1 - V.H)^5`` for B.
    """
    nv = np.clip(np.asarray(n_dot_v, dtype=np.float64), 1e-4, 1.0)[..., None]
    alpha = np.maximum(np.asarray(roughness, dtype=np.float64), 1e-3)[..., None] ** 2
    xi = hammersley(samples)
    # view vector in the x-z plane
    vx, vz = np.sqrt(1.0 - nv * nv), nv
    phi = 2.0 * np.pi * xi[:, 0]
    cos_t = np.sqrt((1.0 - xi[:, 1]) / (1.0 + (alpha * alpha - 1.0) * xi[:, 1]))
    sin_t = np.sqrt(1.0 - cos_t * cos_t)
    hx, hz = sin_t * np.cos(phi), cos_t
    v_dot_h = vx * hx + vz * hz
    l_z = 2.0 * v_dot_h * hz - vz  # N.L of the reflected light direction
    n_dot_l = np.clip(l_z, 0.0, 1.0)
    n_dot_h = np.clip(hz, 0.0, 1.0)
    vh = np.clip(v_dot_h, 0.0, 1.0)
    k = alpha / 2.0
    g = (nv / (nv * (1 - k) + k)) * (n_dot_l / (n_dot_l * (1 - k) + k))
    g_vis = np.where(n_dot_l > 0, g * vh / np.maximum(n_dot_h * nv, 1e-12), 0.0)
    fc = (1.0 - vh) ** 5
    a = np.mean((1.0 - fc) * g_vis, axis=-1)
    b = np.mean(fc * g_vis, axis=-1)
    return np.stack([a, b], axis=-1)


@functools.lru_cache(maxsize=4)
def _lut(size: int, samples: int) -> np.ndarray:
    centres = (np.arange(size, dtype=np.float64) + 0.5) / size
    rough, nv = np.meshgrid(centres, centres, indexing="ij")
    lut = integrate_brdf(nv, rough, samples).astype(np.float32)
    lut.setflags(write=False)
    return lut


def brdf_lut(size: int = LUT_SIZE, samples: int = LUT_SAMPLES) -> np.ndarray:
    """``(size, size, 2)`` float32 (read-only, cached) ``(A, B)``.

    Row ``i`` is roughness ``(i + 0.5) / size``, column ``j`` is ``N.V = (j + 0.5) / size``
    (texel centres, so a texture with u = N.V, v = roughness and linear filtering,
    clamp-to-edge, reads it like ``lookup``).
    """
    return _lut(int(size), int(samples))


def lookup(lut: np.ndarray, n_dot_v: np.ndarray, roughness: np.ndarray) -> np.ndarray:
    """Bilinear, clamp-to-edge read of ``lut`` at texel-centre coordinates; ``(..., 2)`` float32."""
    size_r, size_v = lut.shape[:2]
    x = np.clip(np.asarray(n_dot_v, dtype=np.float64) * size_v - 0.5, 0.0, size_v - 1.0)
    y = np.clip(np.asarray(roughness, dtype=np.float64) * size_r - 0.5, 0.0, size_r - 1.0)
    x0 = np.minimum(np.floor(x).astype(np.int64), size_v - 2)
    y0 = np.minimum(np.floor(y).astype(np.int64), size_r - 2)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    top = lut[y0, x0] * (1 - fx) + lut[y0, x0 + 1] * fx
    bottom = lut[y0 + 1, x0] * (1 - fx) + lut[y0 + 1, x0 + 1] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


def fbeta(albedo: np.ndarray, metallic: np.ndarray, roughness: np.ndarray, n_dot_v: np.ndarray, lut: np.ndarray | None = None) -> np.ndarray:
    """Pre-integrated BRDF ``(..., 3)`` float32 from albedo ``(..., 3)`` and ``(...)`` scalars.

    ``albedo`` is linear RGB; ``metallic``, ``roughness`` and ``n_dot_v`` broadcast against
    ``albedo[..., 0]``.  See the module docstring for the formula.
    """
    lut = brdf_lut() if lut is None else lut
    albedo = np.asarray(albedo, dtype=np.float32)
    m = np.asarray(metallic, dtype=np.float32)[..., None]
    ab = lookup(lut, n_dot_v, roughness)
    f0 = DIELECTRIC_F0 * (1.0 - m) + albedo * m
    diffuse = albedo * (1.0 - m)
    return (diffuse + f0 * ab[..., :1] + ab[..., 1:2]).astype(np.float32)
