"""Tensors crossing the GPU <-> NPU boundary: their manifest entry and how a shader reaches them.

An int8 tensor with scale ``s`` and zero point ``z`` holds codes ``q`` in [-128, 127] for the real
values ``r = s * (q - z)``.  Bundled shaders exchange it through a storage buffer of NHWC bytes
(four per uint32 word, little-endian; ``quant.glsl``), which is exact.  An engine that would
rather bind the NPU tensor memory as a texture needs the texel <-> real maps below; each is
written for GL ES 3.10 normalized-format conversions (a texel value ``v`` is stored as the
integer nearest to ``v * 127`` (SNORM8) or ``v * 255`` (UNORM8), and read back as that integer
divided by 127 or 255, SNORM clamped to -1):

``rgba8i``
    Integer texels hold ``q`` itself: ``r = s * (q - z)``.  Exact.
``snorm8``
    ``v = q / 127``, so ``r = s * (127 v - z) = (127 s) v - s z`` and a shader writes
    ``v = (r / s + z) / 127`` (rounded to a multiple of 1/127 first, or the conversion rounds).
    Not exact: the code -128 cannot be written (the conversion clamps to -127) and reads back as
    -127.  For the usual image tensor (``z = -128``, ``s = 1/255``) that code is black, which
    then reaches the NPU as ``r = s``, one step above black.
``unorm8``
    The texel byte ``u = round(255 v)`` *is* the tensor byte, read by the NPU as two's
    complement: ``q = u`` for ``u <= 127`` and ``q = u - 256`` above.  Exact, piecewise affine:
    ``r = (255 s) v - s z`` for ``u <= 127`` and ``r = (255 s) v - s (z + 256)`` for ``u >= 128``.
    A shader writes ``v = ((q + 256) mod 256) / 255``.

Texel layout equals NHWC only when the channel count is 4; a 3-channel tensor (the image into
the reconstruction net) is reachable only through the buffer.
"""

from __future__ import annotations

import numpy as np

from ..ops.int8.ranges import qrange

BUFFER_PACKING = "NHWC bytes, 4 per uint32 word, little-endian (byte k of word i is element 4i+k)"
WORD_BYTES = 4


def _f(x) -> float:
    return float(x)


def texture_remaps(scale: float, zero_point: int) -> dict:
    """The ``rgba8i`` / ``snorm8`` / ``unorm8`` maps of a per-tensor int8 tensor, as plain data."""
    s, z = np.float64(np.float32(scale)), int(zero_point)
    return {
        "rgba8i": {"exact": True, "real_from_code": {"multiply": _f(s), "add": _f(-s * z)}},
        "snorm8": {
            "exact": False,
            "real_from_texel": {"multiply": _f(127 * s), "add": _f(-s * z)},
            "texel_from_real": {"multiply": _f(1 / (127 * s)), "add": _f(z / 127)},
            "writable_codes": [-127, 127],
            "unreachable_code": -128,
            "unreachable_real": _f(s * (-128 - z)),
            "note": "code -128 cannot be written and reads back as -127",
        },
        "unorm8": {
            "exact": True,
            "code_from_byte": "q = u if u <= 127 else u - 256, u = round(255 v)",
            "pieces": [
                {"bytes": [0, 127], "real_from_texel": {"multiply": _f(255 * s), "add": _f(-s * z)}},
                {"bytes": [128, 255], "real_from_texel": {"multiply": _f(255 * s), "add": _f(-s * (z + 256))}},
            ],
            "texel_from_code": "v = ((q + 256) mod 256) / 255",
        },
    }


def real_from_snorm8(texel: np.ndarray, scale: float, zero_point: int) -> np.ndarray:
    """Real values a shader reconstructs from SNORM8 texel values with :func:`texture_remaps`."""
    m = texture_remaps(scale, zero_point)["snorm8"]["real_from_texel"]
    return np.asarray(texel, np.float64) * m["multiply"] + m["add"]


def real_from_unorm8(texel: np.ndarray, scale: float, zero_point: int) -> np.ndarray:
    """Real values from UNORM8 texel values (bytes reinterpreted as int8) with :func:`texture_remaps`."""
    lo, hi = texture_remaps(scale, zero_point)["unorm8"]["pieces"]
    v = np.asarray(texel, np.float64)
    u = np.rint(v * 255.0)
    low = v * lo["real_from_texel"]["multiply"] + lo["real_from_texel"]["add"]
    high = v * hi["real_from_texel"]["multiply"] + hi["real_from_texel"]["add"]
    return np.where(u <= 127, low, high)


def boundary_entry(
    role: str,
    tensor: str,
    direction: str,
    shape_nhwc: list[int],
    dtype: str,
    scale: float,
    zero_point: int,
    buffer: str,
) -> dict:
    """Manifest entry of one boundary tensor.  ``role``: ``npu_input`` / ``npu_output``;
    ``tensor``: its name in npu.tflite; ``buffer``: the schedule resource that carries it."""
    if dtype != "int8":
        raise ValueError(f"boundary tensor {tensor} is {dtype}; bundles carry int8 boundary tensors")
    qmin, qmax = qrange(dtype)
    s = np.float32(scale)
    count = int(np.prod(shape_nhwc))
    return {
        "role": role,
        "tensor": tensor,
        "direction": direction,
        "layout": "NHWC",
        "dtype": dtype,
        "shape": [int(d) for d in shape_nhwc],
        "scale": float(s),
        "zero_point": int(zero_point),
        "real_range": [float(s * np.float32(qmin - zero_point)), float(s * np.float32(qmax - zero_point))],
        "bytes": count,
        "buffer": {"resource": buffer, "packing": BUFFER_PACKING, "words": -(-count // WORD_BYTES)},
        "texture_remap": texture_remaps(scale, zero_point),
    }
