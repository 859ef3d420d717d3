"""BRDF demodulation and remodulation (reduced FuseSR), and pixel unshuffle of HR G-buffers.

The renderer's shading identity (``render/renderer.py``) holds per RGB channel in linear light::

    colour = emissive + F_beta * L

so the demodulated radiance is ``L = (colour - emissive) / F_beta``.  Where ``F_beta`` is about
zero (sky, black metal) nothing is divided: L is 0 there and the remodulated output is the
emissive buffer (which holds the sky radiance).  Colours cross this module as display values
(``ops.colour.to_display``, exposure 1: the renderer's datasets); L is carried display-encoded
as well, so the network sees values in [0, 1) and the NPU tensors have a fixed range::

    demodulate(colour, F_beta, E)    = to_display(max(from_display(colour) - E, 0) / F_beta)
    add_upsampled(r, l, s)           = clamp(nearest_upsample(l, s) + r, 0, 1): the HR L from the NPU's residual
    remodulate(l, F_beta, E)         = to_display(F_beta * from_display(l) + E), E alone where F_beta < eps

The NPU predicts only the residual over the nearest upsample of its LR L: an identity folded
into its int8 skip conv would set that conv's per-channel weight scale to 1/127 and round
every learned weight beside it to that step.

The torch versions (``model.layers``) and the GLSL passes (``demodulate.glsl``,
``remodulate.glsl``) follow these functions; arrays are ``(..., 3)`` float32.

F_beta and the emissive buffer are engine inputs: each function here that reads them, and
:func:`pixel_unshuffle` (the HR G-buffers' way into the NPU input), passes them through
``ops.sanitize.sanitize_gbuffer`` first, as the GLSL passes do on every texel read, so a NaN or
Inf one frame's G-buffer holds costs that frame only.  On finite values it is the identity.
"""

from __future__ import annotations

import numpy as np

from .colour import from_display, to_display
from .sanitize import sanitize_gbuffer

FBETA_EPSILON = 1e-3  # F_beta below this (per channel) is "about zero": never divided by


def demodulate(color: np.ndarray, fbeta: np.ndarray, emissive: np.ndarray) -> np.ndarray:
    """Display colour, F_beta, linear emissive -> display-encoded L, 0 where F_beta < ``FBETA_EPSILON``
    (F_beta and emissive sanitized: a NaN F_beta is 0, not divided by)."""
    fbeta = sanitize_gbuffer(np.asarray(fbeta, np.float32))
    lit = np.maximum(from_display(color) - sanitize_gbuffer(np.asarray(emissive, np.float32)), np.float32(0))
    safe = np.maximum(fbeta, np.float32(FBETA_EPSILON))
    return np.where(fbeta >= np.float32(FBETA_EPSILON), to_display(lit / safe), np.float32(0)).astype(np.float32)


def remodulate(l: np.ndarray, fbeta: np.ndarray, emissive: np.ndarray) -> np.ndarray:
    """Display-encoded L, F_beta, linear emissive -> display colour in [0, 1); the emissive buffer
    alone where F_beta < ``FBETA_EPSILON`` (the pixels demodulation did not divide; F_beta and
    emissive sanitized)."""
    fbeta = sanitize_gbuffer(np.asarray(fbeta, np.float32))
    reflected = np.where(fbeta >= np.float32(FBETA_EPSILON), fbeta * from_display(l), np.float32(0))
    linear = reflected + sanitize_gbuffer(np.asarray(emissive, np.float32))
    return to_display(np.maximum(linear, np.float32(0)))


def add_upsampled(residual: np.ndarray, l: np.ndarray, scale: int) -> np.ndarray:
    """HR residual ``(H, W, 3)`` plus the nearest upsample of LR ``l`` ``(H/s, W/s, 3)``, clamped to [0, 1]."""
    up = np.repeat(np.repeat(np.asarray(l, np.float32), scale, axis=0), scale, axis=1)
    return np.clip(up + np.asarray(residual, np.float32), np.float32(0), np.float32(1))


def pixel_unshuffle(image: np.ndarray, scale: int) -> np.ndarray:
    """``(H, W, C)`` -> ``(H/s, W/s, C*s*s)``: HR pixel ``(s*i + dy, s*j + dx)`` of channel ``k`` goes to
    LR pixel ``(i, j)``, channel ``k*s*s + dy*s + dx`` (PyTorch's ``pixel_unshuffle`` order).  Values
    pass through ``sanitize_gbuffer`` (NaN -> 0, +-Inf -> +-COLOUR_MAX; finite values unchanged): the HR
    G-buffers an engine hands over reach the NPU input this way."""
    h, w, c = image.shape
    tiles = sanitize_gbuffer(np.asarray(image)).reshape(h // scale, scale, w // scale, scale, c)
    return np.ascontiguousarray(tiles.transpose(0, 2, 4, 1, 3).reshape(h // scale, w // scale, c * scale * scale))
