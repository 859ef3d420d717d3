"""Reference TAAU accumulation (numpy, one frame, ``(H, W, C)``): the definition the torch
``model.taau`` (the baseline and the ``ntaau`` family) is tested against, and the one the GPU
passes of the family follow.

See ``model.taau`` for the method.  Conventions are ``ops.conventions``: pixel centres at +0.5,
clamp-to-edge borders, jitter ``(2,)`` in LR pixels, motion pointing to the previous frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scale import hr_size_for, is_integer, resize_bilinear
from .warp import offscreen, upsample_motion, warp_bilinear

CUBIC_A = -0.75  # the bicubic kernel's free parameter (PyTorch's and OpenCV's)
RGB_TO_YCOCG = np.array([[0.25, 0.5, 0.25], [0.5, 0.0, -0.5], [-0.25, 0.5, -0.25]], np.float32)
YCOCG_TO_RGB = np.array([[1.0, 1.0, -1.0], [1.0, 0.0, 1.0], [1.0, -1.0, -1.0]], np.float32)


def rgb_to_ycocg(x: np.ndarray) -> np.ndarray:
    return np.asarray(x, np.float32) @ RGB_TO_YCOCG.T


def ycocg_to_rgb(x: np.ndarray) -> np.ndarray:
    return np.asarray(x, np.float32) @ YCOCG_TO_RGB.T


def hr_dims(lr_hw, scale, hr_size=None) -> tuple[int, int]:
    """``(H, W)`` for an LR image of ``(h, w)``: ``hr_size`` ``(W, H)`` when given, else ``lr * s`` at
    an integer scale and ``ops.scale.hr_size_for`` at a fractional one (``model.taau.hr_dims``)."""
    h, w = int(lr_hw[0]), int(lr_hw[1])
    if hr_size is not None:
        return int(hr_size[1]), int(hr_size[0])
    if is_integer(scale):
        return h * int(scale), w * int(scale)
    width, height = hr_size_for((w, h), scale)
    return height, width


def is_tiled(lr_hw, hr_hw, scale) -> bool:
    """An integer scale at exactly ``lr * s``: the integer code paths, bit for bit."""
    return is_integer(scale) and tuple(hr_hw) == (int(lr_hw[0]) * int(scale), int(lr_hw[1]) * int(scale))


def nearest_index(n_hr: int, n_lr: int) -> np.ndarray:
    """The LR pixel of each HR pixel along one axis: ``floor((X + 0.5) lr / hr)``, exactly (``X // s``
    at an integer scale)."""
    return ((2 * np.arange(n_hr, dtype=np.int64) + 1) * n_lr) // (2 * n_hr)


def nearest_up(x: np.ndarray, s, hr_size=None) -> np.ndarray:
    """``(h, w, C)`` -> ``(H, W, C)``, each HR pixel its LR pixel (``nearest_index``)."""
    hr_hw = hr_dims(x.shape[:2], s, hr_size)
    if is_tiled(x.shape[:2], hr_hw, s):
        s = int(s)
        return np.repeat(np.repeat(x, s, axis=0), s, axis=1)
    return x[nearest_index(hr_hw[0], x.shape[0])][:, nearest_index(hr_hw[1], x.shape[1])]


def hr_motion_of(motion: np.ndarray, scale, hr_size=None) -> np.ndarray:
    """LR motion (h, w, 2) in LR pixels -> HR motion in HR pixels (``ops.scale.upsample_motion_to``:
    ``ops.warp.upsample_motion`` at an integer scale, else bilinear times each axis's exact ratio)."""
    motion = np.asarray(motion, np.float32)
    hr_hw = hr_dims(motion.shape[:2], scale, hr_size)
    if is_tiled(motion.shape[:2], hr_hw, scale):
        return upsample_motion(motion, int(scale))
    h, w = motion.shape[:2]
    ratio = np.array([hr_hw[1] / w, hr_hw[0] / h], dtype=np.float32)
    return resize_bilinear(motion, (hr_hw[1], hr_hw[0])) * ratio  # upsample_motion_to's fractional branch


def cubic_weights(t: np.ndarray) -> np.ndarray:
    """``(..., 4)`` weights of the taps at -1, 0, 1, 2 for the fractional position ``t``."""
    a = CUBIC_A
    d = np.stack([t + 1.0, t, 1.0 - t, 2.0 - t], axis=-1)
    near = ((a + 2.0) * d - (a + 3.0)) * d * d + 1.0  # |d| <= 1
    far = ((a * d - 5.0 * a) * d + 8.0 * a) * d - 4.0 * a  # 1 < |d| < 2
    return np.where(d <= 1.0, near, far).astype(np.float32)


def bicubic_upsample(color: np.ndarray, jitter, scale, hr_size=None) -> np.ndarray:
    """Jitter-aware bicubic ``(h, w, C)`` -> ``(h*s, w*s, C)`` (``(H, W, C)`` at a fractional scale:
    HR centre ``X + 0.5`` at LR ``(X + 0.5) w / W``), not clamped: the LR texel ``(i, j)`` sits at
    ``(j + 0.5 + jx, i + 0.5 + jy)``; each tap's index is clamped to the edge."""
    h, w = color.shape[:2]
    hh, ww = hr_dims((h, w), scale, hr_size)
    tiled = is_tiled((h, w), (hh, ww), scale)
    jx, jy = (float(v) for v in np.asarray(jitter, np.float32).reshape(2))

    def taps(n_lr: int, n_hr: int, shift: float):
        if tiled:
            u = (np.arange(n_hr, dtype=np.float64) + 0.5) / int(scale) - shift - 0.5  # texel-index coordinate
        else:
            u = (np.arange(n_hr, dtype=np.float64) + 0.5) * (n_lr / n_hr) - shift - 0.5
        base = np.floor(u)
        index = np.clip(base[:, None].astype(np.int64) + np.arange(-1, 3), 0, n_lr - 1)
        return index, cubic_weights(u - base)

    rows, wy = taps(h, hh, jy)
    cols, wx = taps(w, ww, jx)
    out = np.zeros((hh, ww, color.shape[2]), np.float64)
    for a in range(4):
        for b in range(4):
            out += (wy[:, a, None, None] * wx[None, :, b, None]) * color[rows[:, a]][:, cols[:, b]]
    return out.astype(np.float32)


def nearby_samples(current: np.ndarray, jitter, scale, sigma: float, hr_size=None) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian-weighted mean ``(H, W, 3)`` of the 3x3 LR samples around each HR pixel, and their
    total weight ``(H, W, 1)``; HR pixel ``(Y, X)`` belongs to LR pixel ``nearest_index`` and sample
    ``(i, j)`` sits at HR ``rx (j + 0.5 + jx), ry (i + 0.5 + jy)``, ``rx = W / w``, ``ry = H / h``."""
    h, w = current.shape[:2]
    hh, ww = hr_dims((h, w), scale, hr_size)
    rx, ry = ww / w, hh / h
    jx, jy = (float(v) for v in np.asarray(jitter, np.float32).reshape(2))
    padded = np.pad(current, ((1, 1), (1, 1), (0, 0)), mode="edge")
    hr_y, hr_x = np.arange(hh) + 0.5, np.arange(ww) + 0.5
    lr_y, lr_x = nearest_index(hh, h) + 0.5, nearest_index(ww, w) + 0.5
    acc = np.zeros((hh, ww, current.shape[2]), np.float64)
    total = np.zeros((hh, ww, 1), np.float64)
    for dy in (-1, 0, 1):
        wy = np.exp(-0.5 * (((lr_y + dy + jy) * ry - hr_y) / sigma) ** 2)
        for dx in (-1, 0, 1):
            wx = np.exp(-0.5 * (((lr_x + dx + jx) * rx - hr_x) / sigma) ** 2)
            weight = (wy[:, None] * wx[None, :])[..., None]
            acc += weight * nearest_up(padded[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w], scale, (ww, hh))
            total += weight
    return (acc / np.maximum(total, 1e-12)).astype(np.float32), total.astype(np.float32)


def neighbourhood_box(current: np.ndarray, scale, clip: str = "minmax", gamma: float = 1.25,
                      hr_size=None) -> tuple[np.ndarray, np.ndarray]:
    """Per-HR-pixel colour box ``(lo, hi)``, each ``(H, W, C)``, from the 3x3 LR neighbourhood
    (min/max, or mean +- ``gamma`` std with ``clip="variance"``)."""
    h, w = current.shape[:2]
    padded = np.pad(current, ((1, 1), (1, 1), (0, 0)), mode="edge")
    window = np.stack([padded[dy : dy + h, dx : dx + w] for dy in range(3) for dx in range(3)])
    if clip == "minmax":
        lo, hi = window.min(axis=0), window.max(axis=0)
    else:
        mean = window.mean(axis=0)
        std = np.sqrt(np.maximum((window * window).mean(axis=0) - mean * mean, 0.0))
        lo, hi = mean - gamma * std, mean + gamma * std
    return nearest_up(lo, scale, hr_size), nearest_up(hi, scale, hr_size)


def undo_bilinear_blur(image: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """First-order inverse of a bilinear fetch's blur; ``spread`` ``(H, W, 2)`` is ``f (1 - f)`` per axis."""
    p = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="edge")
    centre = p[1:-1, 1:-1]
    dxx = p[1:-1, :-2] + p[1:-1, 2:] - 2.0 * centre
    dyy = p[:-2, 1:-1] + p[2:, 1:-1] - 2.0 * centre
    return (image - 0.5 * (spread[..., :1] * dxx + spread[..., 1:] * dyy)).astype(np.float32)


def reprojected_history(history: np.ndarray, weight: np.ndarray, motion: np.ndarray, reset: bool, scale,
                        sharpen: bool = True, blur_penalty: float = 1.5) -> tuple[np.ndarray, np.ndarray]:
    """The previous output ``history`` (H, W, 3) RGB and its weight (H, W, 1) warped by the LR
    ``motion`` (h, w, 2) upsampled to the history's size (``hr_motion_of``): YCoCg colour (blur
    undone), weight scaled by the blur penalty and zero after a reset and where the motion leaves
    the frame."""
    hr_motion = hr_motion_of(motion, scale, (history.shape[1], history.shape[0]))
    warped = warp_bilinear(np.concatenate([history, weight], axis=-1), hr_motion)
    spread = resample_spread(hr_motion)
    colour = undo_bilinear_blur(warped[..., :3], spread) if sharpen else warped[..., :3]
    keep = (~offscreen(hr_motion))[..., None] & (not reset)
    new_weight = warped[..., 3:] * keep * np.exp(-blur_penalty * spread.sum(axis=-1, keepdims=True))
    return rgb_to_ycocg(colour), new_weight.astype(np.float32)


def resample_spread(hr_motion: np.ndarray) -> np.ndarray:
    """``f (1 - f)`` per axis (H, W, 2) for the fractional part ``f`` of the HR motion (H, W, 2):
    the variance a bilinear fetch of the history there blurs it by."""
    frac = hr_motion - np.floor(hr_motion)
    return (frac * (1.0 - frac)).astype(np.float32)


def filter_gain(motion: np.ndarray, scale, falloff: float, hr_size=None):
    """What the display filter's weights are scaled by per HR pixel (H, W, 1): ``exp(-falloff (sx +
    sy))`` with the resample spread ``sx, sy`` of the HR motion upsampled from the LR ``motion``
    (h, w, 2), so the filter blurs less where a fractional fetch has just blurred the history; 1 when
    ``falloff`` is 0, the motion then not read."""
    if falloff <= 0.0:
        return np.float32(1.0)
    spread = resample_spread(hr_motion_of(motion, scale, hr_size))
    return np.exp(-np.float32(falloff) * spread.sum(axis=-1, keepdims=True)).astype(np.float32)


def current_terms(colour: np.ndarray, jitter, scale, sigma: float, hr_size=None):
    """What one frame's LR ``colour`` (h, w, 3) RGB gives the blend, all YCoCg at HR: the nearby
    samples' mean and total weight, the bicubic frame and the clamp box ``(lo, hi)``."""
    current = rgb_to_ycocg(colour)
    samples, sample_weight = nearby_samples(current, jitter, scale, sigma, hr_size)
    spatial = rgb_to_ycocg(bicubic_upsample(colour, jitter, scale, hr_size))
    return samples, sample_weight, spatial, *neighbourhood_box(current, scale, hr_size=hr_size)


def steering_features(colour: np.ndarray, history: np.ndarray, history_weight: np.ndarray, scale: int,
                      max_weight: float) -> np.ndarray:
    """The ``ntaau`` net's input (h, w, 3 + 5 s^2): the LR colour, then the reprojected YCoCg
    ``history`` (H, W, 3) clamped to the box, its weight / ``max_weight`` and the clamp distance,
    pixel-unshuffled (``ops.demodulation.pixel_unshuffle`` order)."""
    from .demodulation import pixel_unshuffle

    lo, hi = neighbourhood_box(rgb_to_ycocg(colour), scale)
    clamped = np.minimum(np.maximum(history, lo), hi)
    distance = np.abs(history - clamped).sum(axis=-1, keepdims=True)
    hr = np.concatenate([clamped, history_weight / np.float32(max_weight), distance], axis=-1)
    return np.concatenate([np.asarray(colour, np.float32), pixel_unshuffle(hr, scale)], axis=-1)


@dataclass
class Steer:
    """Per-HR-pixel steering, each ``(H, W, 1 or 3)`` or a scalar (``model.taau.Steer``)."""

    history_gain: np.ndarray | float = 1.0
    sample_gain: np.ndarray | float = 1.0
    box_widen: np.ndarray | float = 0.0
    correction: np.ndarray | float = 0.0
    filter_axis: np.ndarray | float = 0.0
    filter_diagonal: np.ndarray | float = 0.0
    # spatial fallback in [0, 1]: the blend moves this far to the bicubic ``spatial`` and its
    # accumulated weight shrinks by as much (``ntaau_lr``: a history that cannot be trusted is not kept)
    fallback: np.ndarray | float = 0.0


def history_floor(motion: np.ndarray, scale, history_gain_min: float, still_motion_px: float, hr_size=None):
    """The least history gain per HR pixel: ``history_gain_min`` where the surface moved less than
    ``still_motion_px`` HR pixels, fading linearly to 0 at that motion (the length of the HR motion
    upsampled from the LR ``motion`` (h, w, 2)); ``history_gain_min`` everywhere when
    ``still_motion_px`` is 0, the motion then not read."""
    if still_motion_px <= 0.0:
        return np.float32(history_gain_min)
    ramp = np.clip(1.0 - motion_length(motion, scale, hr_size) / np.float32(still_motion_px), 0.0, 1.0)
    return (np.float32(history_gain_min) * ramp).astype(np.float32)


def motion_length(motion: np.ndarray, scale, hr_size=None) -> np.ndarray:
    """(H, W, 1): the length of the HR motion upsampled from the LR ``motion`` (h, w, 2), HR pixels."""
    hr = hr_motion_of(motion, scale, hr_size)
    return np.sqrt((hr * hr).sum(axis=-1, keepdims=True)).astype(np.float32)


def box_widening(raw: np.ndarray, box_bound: float) -> np.ndarray:
    """The clamp box's widening per side in units of its span: ``box_bound`` tanh where the raw value
    is positive (the box widens), 0.5 tanh where it is negative (the box narrows, at most to its
    centre; a narrower box would be inverted)."""
    t = np.tanh(np.asarray(raw, np.float32))
    return np.where(t > 0, np.float32(box_bound) * t, np.float32(0.5) * t).astype(np.float32)


def steer_from_raw(raw: np.ndarray, correction_bound: float, history_gain_min=0.0,
                   filter_bound: float = 0.0, box_bound: float = 0.5, filter_scale=1.0) -> Steer:
    """The ``ntaau`` net's raw output (H, W, 6 or 8) mapped to its ranges: gains 2 sigmoid in (0, 2),
    the history gain at least ``history_gain_min``, box widening ``box_widening``, correction
    ``correction_bound`` tanh and, with 8 channels, the display filter's weights ``filter_bound`` tanh
    times ``filter_scale`` (``filter_gain``)."""
    raw = np.asarray(raw, np.float32)
    sigmoid = lambda x: 1.0 / (1.0 + np.exp(-x))  # noqa: E731
    history_gain = np.maximum(2.0 * sigmoid(raw[..., 0:1]), np.asarray(history_gain_min, np.float32))
    steer = Steer(history_gain=history_gain, sample_gain=2.0 * sigmoid(raw[..., 1:2]),
                  box_widen=box_widening(raw[..., 2:3], box_bound), correction=correction_bound * np.tanh(raw[..., 3:6]))
    if raw.shape[-1] > 6:
        steer.filter_axis = (np.float32(filter_bound) * np.tanh(raw[..., 6:7]) * filter_scale).astype(np.float32)
        steer.filter_diagonal = (np.float32(filter_bound) * np.tanh(raw[..., 7:8]) * filter_scale).astype(np.float32)
    return steer


def display_filter(image: np.ndarray, axis, diagonal) -> np.ndarray:
    """``image`` (H, W, C) plus ``axis`` times each of its 4 axis neighbours' differences to it and
    ``diagonal`` times each of the 4 diagonal ones' (clamp-to-edge): the per-pixel 3x3 filter the
    ``ntaau`` net steers (weights > 0 blur, < 0 sharpen; the taps sum to one)."""
    p = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="edge")
    centre = p[1:-1, 1:-1]
    axial = p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:] - 4.0 * centre
    diagonals = p[:-2, :-2] + p[:-2, 2:] + p[2:, :-2] + p[2:, 2:] - 4.0 * centre
    return (image + axis * axial + diagonal * diagonals).astype(np.float32)


def display(history: np.ndarray, steer: Steer) -> np.ndarray:
    """The displayed RGB (H, W, 3) in [0, 1]: the blended ``history`` (RGB) through the display
    filter, plus the YCoCg correction."""
    filtered = display_filter(history, steer.filter_axis, steer.filter_diagonal)
    correction = ycocg_to_rgb(np.broadcast_to(np.asarray(steer.correction, np.float32), history.shape))
    return np.clip(filtered + correction, 0.0, 1.0).astype(np.float32)


def blend(samples, sample_weight, spatial, lo, hi, history, history_weight, prior_weight: float, max_weight: float,
          steer: Steer = Steer()) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One steered TAAU step (inputs in YCoCg): the displayed RGB (H, W, 3) in [0, 1], the next
    history (the blend, RGB in [0, 1]) and its accumulated weight (H, W, 1).  The display is that
    history through the display filter plus the correction: neither builds up in the history.  A
    fallback moves the blend toward ``spatial`` before it becomes the history."""
    span = hi - lo
    clamped = np.minimum(np.maximum(history, lo - steer.box_widen * span), hi + steer.box_widen * span)
    weight = history_weight * steer.history_gain
    current = sample_weight * steer.sample_gain
    mixed = (weight * clamped + current * samples + prior_weight * spatial) / (weight + current + prior_weight)
    accumulated = np.minimum(weight + current, max_weight).astype(np.float32)
    if not (np.isscalar(steer.fallback) and steer.fallback == 0.0):
        mixed = mixed + steer.fallback * (spatial - mixed)
        accumulated = (accumulated * (np.float32(1.0) - steer.fallback)).astype(np.float32)
    next_history = np.clip(ycocg_to_rgb(mixed), 0.0, 1.0)
    output = display(next_history, steer)
    return output, next_history.astype(np.float32), accumulated
