"""MNSS inpainting: the weight map M_w and the rectified history (reference definition).

Per frame, with the warped history I_W (HR) and D_W (depth, here only at this frame's sampled
sub-pixels), the current LR colour and depth:

    difference  |colour - I_W|, |depth - D_W| at the sampled sub-pixels   (h, w, 4)
    LR weights  activation(conv3x3(difference) + bias)                   (h, w, 1) in [0, 1]
    M_w         LR weights upsampled: bilinear at the jittered sample positions, or replicated
    I_R         M_w I_U + (1 - M_w) I_W,  I_U = ``subpixel.jittered_upsample`` of the colour

``conv3x3`` is also the layer of the anti-aliasing net (a stack of them with ReLU).
Everything is float32; the comments give the order of the float operations, which the GPU
passes follow.
"""

from __future__ import annotations

import numpy as np

from .int8.logistic_tanh import sigmoid_f32
from .resample import upsample_bilinear

ACTIVATIONS = ("sigmoid", "tanh")  # tanh is clipped to [0, 1]
WEIGHT_UPSAMPLES = ("bilinear", "nearest")


def conv3x3(image: np.ndarray, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """3x3 convolution, stride 1, zero padding 1: ``(h, w, Cin)`` -> ``(h, w, Cout)`` float32.

    ``weight`` is ``(Cout, Cin, 3, 3)`` (PyTorch's layout), ``bias`` ``(Cout,)``.  The float32
    accumulator starts at the bias and adds taps in row-major order (ky, kx), input channels
    in order within a tap.
    """
    x = np.asarray(image, dtype=np.float32)
    w = np.asarray(weight, dtype=np.float32)
    h, wd, cin = x.shape
    if w.shape[1:] != (cin, 3, 3):
        raise ValueError(f"weight {w.shape} does not fit a 3x3 conv on {cin} channels")
    padded = np.pad(x, ((1, 1), (1, 1), (0, 0)))
    acc = np.broadcast_to(np.asarray(bias, dtype=np.float32), (h, wd, w.shape[0])).copy()
    for ky in range(3):
        for kx in range(3):
            window = padded[ky : ky + h, kx : kx + wd]
            for c in range(cin):
                acc += window[..., c : c + 1] * w[:, c, ky, kx]
    return acc


def activate(x: np.ndarray, activation: str) -> np.ndarray:
    """``sigmoid`` (``1 / (1 + exp(-x))``) or ``tanh`` clipped to [0, 1], float32."""
    if activation == "sigmoid":
        return sigmoid_f32(x)
    if activation == "tanh":
        return np.clip(np.tanh(np.asarray(x, dtype=np.float32)), 0.0, 1.0).astype(np.float32)
    raise ValueError(f"unknown inpainting activation {activation!r} (one of {', '.join(ACTIVATIONS)})")


def difference(color: np.ndarray, depth: np.ndarray, past_color: np.ndarray, past_depth: np.ndarray) -> np.ndarray:
    """``(h, w, 4)`` float32: ``|colour - past colour|`` (3) and ``|depth - past depth|`` (1), all LR.

    ``past_*`` are the warped history at this frame's sampled sub-pixels
    (``subpixel.extract_samples``).
    """
    rgb = np.abs(np.asarray(color, np.float32) - np.asarray(past_color, np.float32))
    d = np.abs(np.asarray(depth, np.float32) - np.asarray(past_depth, np.float32))
    return np.concatenate([rgb, d], axis=-1)


def lr_weights(
    color: np.ndarray,
    depth: np.ndarray,
    past_color: np.ndarray,
    past_depth: np.ndarray,
    weight: np.ndarray,
    bias: np.ndarray,
    activation: str = "sigmoid",
    conv=conv3x3,
    invalid: np.ndarray | None = None,
) -> np.ndarray:
    """LR weights ``(h, w, 1)`` float32 in [0, 1]: 1 = take the current frame, 0 = keep the history.

    ``weight`` ``(1, 4, 3, 3)`` and ``bias`` ``(1,)`` are the learned conv.  ``conv`` computes
    it: :func:`conv3x3` or an implementation with identical values (a faster one).  ``invalid``
    ``(h, w, 1)`` bool (``ops.sanitize.colour_not_finite`` of the engine's colour) or None: those
    samples are no samples, their weight is 0 (the history is kept).
    """
    lr = activate(conv(difference(color, depth, past_color, past_depth), weight, bias), activation)
    return lr if invalid is None else np.where(invalid, np.float32(0), lr).astype(np.float32)


def weight_map(lr: np.ndarray, jitter: tuple[float, float], scale: int, mode: str = "bilinear") -> np.ndarray:
    """M_w ``(h*s, w*s, 1)`` float32 from LR weights ``(h, w, 1)``.

    ``bilinear``: the LR weights belong to the jittered sample positions
    (``resample.upsample_bilinear`` with the jitter as offset); ``nearest``: each weight covers
    its ``s x s`` tile.
    """
    if mode == "nearest":
        return np.repeat(np.repeat(np.asarray(lr, np.float32), scale, axis=0), scale, axis=1)
    if mode == "bilinear":
        return upsample_bilinear(lr, scale, offset=(float(jitter[0]), float(jitter[1])))
    raise ValueError(f"unknown weight upsampling {mode!r} (one of {', '.join(WEIGHT_UPSAMPLES)})")


def rectify(upsampled: np.ndarray, warped: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """I_R = ``weight * upsampled + (1 - weight) * warped`` (float32, in that order); shapes broadcast."""
    m = np.asarray(weight, np.float32)
    return (m * np.asarray(upsampled, np.float32) + (np.float32(1) - m) * np.asarray(warped, np.float32)).astype(np.float32)
