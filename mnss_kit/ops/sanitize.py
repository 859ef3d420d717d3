"""Input sanitization: what the first GPU pass does to a NaN or an Inf in an engine's input.

One bad frame must cost one frame: a shader bug or a sky at infinite depth can write NaN or Inf
into the colour, depth or motion an engine hands over, and a NaN that reaches the history stays
there (every later blend with it is NaN).  Every read of an engine input by a GPU pass goes through
these definitions (GLSL: ``sanitize_colour`` / ``sanitize_depth`` / ``sanitize_motion`` /
``sanitize_gbuffer`` in ``shaders/runtime/common.glsl``; torch: ``mnss_kit.model.taau.sanitize_*``).

Each function is the identity on the finite values its texture format holds, so a bundle's output
on finite inputs is bit-identical with or without it.

- colour (``rgba16f``): NaN -> 0; +-Inf and finite values beyond it -> +-``COLOUR_MAX``, the
  largest finite fp16.  The format's maximum rather than 1.0: clamping to [0, 1] would change
  display values an engine writes slightly out of range (and linear HDR colour), so the sanitize
  would no longer be an identity on finite inputs; the blend clamps its result to [0, 1] anyway,
  so a saturated sample costs its own frame only.
- depth (canonical linear depth in [0, 1], ``r32f``): NaN and +-Inf -> ``FAR_DEPTH`` (1.0, the far
  plane): a sky written at infinite depth is far, and a NaN has no better guess.
- motion (LR pixels, ``rg32f``): NaN and +-Inf -> 0 per component (the surface did not move).
- material G-buffers (F_beta, emissive, normal, albedo; ``rgba16f``, FuseSR reads them): NaN -> 0,
  +-Inf -> +-``COLOUR_MAX``, finite values unchanged (no fp16 texel holds a finite value beyond
  ``COLOUR_MAX``, so on a texture's contents this is the colour's rule).  A NaN F_beta becomes 0:
  "about zero", the pixel is not demodulated and remodulates to its emissive alone.

Values are float32 throughout; the input's dtype is kept.

A sanitized colour is a guess, not a sample.  A family whose history would keep the guess says
where it was made (:func:`colour_not_finite`) and treats that sample as no sample: MNSS keeps the
warped history there (its inpainting weight is 0) and inserts no anti-aliased value at its
sub-pixel (the AA pass writes ``NO_SAMPLE`` there, ``ops.subpixel.insert_valid_samples`` skips it).
"""

from __future__ import annotations

import numpy as np

COLOUR_MAX = 65504.0  # the largest finite IEEE binary16
FAR_DEPTH = 1.0       # canonical depth of the far plane (ops.conventions)
NO_SAMPLE = -1.0      # a display value in [0, 1] never is: marks an LR sample that is no sample


def sanitize_colour(color: np.ndarray) -> np.ndarray:
    """Colour (any shape), NaN -> 0, clamped to [-COLOUR_MAX, COLOUR_MAX] (+-Inf included)."""
    x = np.asarray(color)
    return np.where(np.isnan(x), 0.0, np.clip(x, -COLOUR_MAX, COLOUR_MAX)).astype(x.dtype)


def sanitize_depth(depth: np.ndarray) -> np.ndarray:
    """Canonical depth (any shape), NaN and +-Inf -> FAR_DEPTH; finite values unchanged."""
    x = np.asarray(depth)
    return np.where(np.isfinite(x), x, FAR_DEPTH).astype(x.dtype)


def sanitize_motion(motion: np.ndarray) -> np.ndarray:
    """Motion (any shape), NaN and +-Inf -> 0 per component; finite values unchanged."""
    x = np.asarray(motion)
    return np.where(np.isfinite(x), x, 0.0).astype(x.dtype)


def sanitize_gbuffer(gbuffer: np.ndarray) -> np.ndarray:
    """A material G-buffer (any shape), NaN -> 0, +-Inf -> +-COLOUR_MAX; finite values unchanged."""
    x = np.asarray(gbuffer)
    return np.where(np.isnan(x), 0.0, np.where(np.isinf(x), np.copysign(COLOUR_MAX, x), x)).astype(x.dtype)


def colour_not_finite(color: np.ndarray) -> np.ndarray:
    """``(..., C)`` colour -> ``(..., 1)`` bool: NaN or +-Inf in any of its first three channels (rgb)."""
    x = np.asarray(color)
    return ~np.all(np.isfinite(x[..., :3]), axis=-1, keepdims=True)
