"""Reference definitions of the ``ntaau_lr`` family's own steps (numpy, one frame, ``(h, w, C)``):
the evidence the GPU gathers at LR (depth change, motion spread, trust), the 8 steering features
(and the detail branch's inputs), the LR steering upsampled to HR and mapped to a
:class:`~.taau.Steer`, and the detail branch's luma patch drawn at HR.  The torch model
(``model.ntaau_lr.net``) and the GLSL passes (``taau_lr*.comp``) are tested against these; the
accumulation itself is ``ops.taau``'s.

Conventions are ``ops.conventions``: pixel centres at +0.5, clamp-to-edge, motion in LR pixels
pointing to the previous frame.
"""

from __future__ import annotations

import numpy as np

from .demodulation import pixel_unshuffle
from .resample import avgpool, upsample_bilinear
from .scale import resize_bilinear
from .taau import Steer, box_widening, hr_dims, is_tiled, nearest_index, neighbourhood_box, rgb_to_ycocg
from .warp import warp_bilinear

DEPTH_FLOOR = 1e-4  # depth below which the relative change is taken against this (model.ntaau_lr.net)
SPREAD_CAP = 4.0  # the motion spread feature is capped here (LR pixels)
STEER_CHANNELS = 6  # raw LR steering values: history gain, sample gain, box widening, fallback, filter (2); a detail branch's 4 follow


def nearest_depth(previous: np.ndarray) -> np.ndarray:
    """The nearest (smallest) of each pixel's 3x3 depths, edges repeated: (h, w, 1)."""
    h, w = previous.shape[:2]
    p = np.pad(np.asarray(previous, np.float32), ((1, 1), (1, 1), (0, 0)), mode="edge")
    return np.stack([p[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)]).min(axis=0)


def depth_change(depth: np.ndarray, previous: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """Relative depth change (h, w, 1) in [-1, 1]: this depth minus the nearest of the last frame's
    3x3 depths fetched bilinearly where the pixel was, over this depth; > 0 at a disocclusion."""
    depth = np.asarray(depth, np.float32)
    reprojected = warp_bilinear(nearest_depth(previous), np.asarray(motion, np.float32))
    change = (depth - reprojected) / np.maximum(depth, np.float32(DEPTH_FLOOR))
    return np.clip(change, -1.0, 1.0).astype(np.float32)


def motion_spread(motion: np.ndarray) -> np.ndarray:
    """The largest L1 difference (LR pixels) between a pixel's motion and one of its 8 neighbours' (h, w, 1)."""
    h, w = motion.shape[:2]
    m = np.asarray(motion, np.float32)
    p = np.pad(m, ((1, 1), (1, 1), (0, 0)), mode="edge")
    diffs = [np.abs(p[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] - m).sum(axis=-1, keepdims=True)
             for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    return np.stack(diffs).max(axis=0).astype(np.float32)


def trust(change: np.ndarray, spread: np.ndarray, trust_depth: float, trust_spread_px: float) -> np.ndarray:
    """How much history trust above TAAU's the evidence allows, in [0, 1] per LR pixel."""
    t = 1.0 - np.maximum(change, 0.0) / np.float32(trust_depth) - spread / np.float32(trust_spread_px)
    return np.clip(t, 0.0, 1.0).astype(np.float32)


def evidence(depth, previous, motion, trust_depth: float, trust_spread_px: float) -> np.ndarray:
    """(h, w, 4): depth change, motion spread, trust, 0 (the layout of ``taau_lr_evidence_pass``)."""
    change, spread = depth_change(depth, previous, motion), motion_spread(motion)
    return np.concatenate([change, spread, trust(change, spread, trust_depth, trust_spread_px),
                           np.zeros_like(change)], axis=-1)


def pad_even(x: np.ndarray) -> np.ndarray:
    """``x`` (h, w, C) padded at the bottom and right (edge values) to an even height and width."""
    h, w = x.shape[:2]
    return np.pad(x, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")


def block_mean(x: np.ndarray, lr_hw, scale) -> np.ndarray:
    """The mean of each LR pixel's HR block ``(H, W, C)`` -> ``(h, w, C)``: the HR pixels whose nearest
    LR pixel it is (``ops.taau.nearest_index``; contiguous runs of 1 or 2 at 1.5x); ``avgpool`` over
    ``s x s`` tiles at an integer scale (``model.taau.block_mean``)."""
    h, w = int(lr_hw[0]), int(lr_hw[1])
    if is_tiled((h, w), x.shape[:2], scale):
        return avgpool(x, int(scale))
    x = np.asarray(x, np.float32)
    rows, cols = nearest_index(x.shape[0], h), nearest_index(x.shape[1], w)
    starts_y, starts_x = np.searchsorted(rows, np.arange(h)), np.searchsorted(cols, np.arange(w))
    sums = np.add.reduceat(np.add.reduceat(x, starts_y, axis=0), starts_x, axis=1)
    count = np.diff(np.append(starts_y, x.shape[0]))[:, None, None] * np.diff(np.append(starts_x, x.shape[1]))[None, :, None]
    return (sums / count.astype(np.float32)).astype(np.float32)


def steering_features(colour: np.ndarray, history: np.ndarray, history_weight: np.ndarray, change: np.ndarray,
                      spread: np.ndarray, scale, max_weight: float, scale_input: float = 0.0,
                      detail: bool = False) -> np.ndarray:
    """The steering net's input (h', w', 8), padded to an even size: the LR colour, the clamped YCoCg
    ``history``'s luma minus the colour's, the clamp distance and ``history_weight / max_weight``
    (each the mean over the pixel's HR block, ``block_mean``), the depth change and the spread
    (capped); with ``scale_input`` (its value, ``1 / scale``, or True for ``1 / scale``) a 9th channel
    of that constant; with ``detail`` (an integer scale) then ``s * s`` channels, the clamped
    history's luma at each HR pixel of the LR pixel's block, channel ``dy * s + dx``
    (``ops.demodulation.pixel_unshuffle``: the detail branch's input).  The HR size is the history's."""
    colour = np.asarray(colour, np.float32)
    lr_hw = colour.shape[:2]
    hr_size = (history.shape[1], history.shape[0])
    lo, hi = neighbourhood_box(rgb_to_ycocg(colour), scale, hr_size=hr_size)
    clamped = np.minimum(np.maximum(history, lo), hi)
    distance = block_mean(np.abs(history - clamped).sum(axis=-1, keepdims=True), lr_hw, scale)
    weight = block_mean(history_weight, lr_hw, scale) / np.float32(max_weight)
    luma_gap = block_mean(clamped[..., :1], lr_hw, scale) - rgb_to_ycocg(colour)[..., :1]
    capped = np.minimum(spread, np.float32(SPREAD_CAP))
    parts = [colour, luma_gap, distance, weight, change, capped]
    if scale_input:
        value = 1.0 / float(scale) if scale_input is True else float(scale_input)
        parts.append(np.full_like(capped, np.float32(value)))
    if detail:
        if not is_tiled(lr_hw, clamped.shape[:2], scale):
            raise ValueError(f"the detail branch's inputs take an integer scale with HR = LR x scale, got {scale}")
        parts.append(pixel_unshuffle(clamped[..., :1], int(scale)))
    return pad_even(np.concatenate(parts, axis=-1).astype(np.float32))


def detail_luma(raw: np.ndarray, hr_hw, bound: float) -> np.ndarray:
    """The detail patches (h, w, 4; the raw values, the net's padded output cropped) drawn at HR
    (H, W, 1) (``model.ntaau_lr.net.detail_luma``): each HR pixel takes its nearest LR pixel's patch,
    bilinear through the patch's values ``bound tanh(raw)`` placed at (-1/4, -1/4), (+1/4, -1/4),
    (-1/4, +1/4), (+1/4, +1/4) LR pixels from that pixel's centre; at x2 a pixel shuffle."""
    h, w = raw.shape[:2]
    values = np.float32(bound) * np.tanh(np.asarray(raw, np.float32))
    values = values[nearest_index(hr_hw[0], h)][:, nearest_index(hr_hw[1], w)]
    tx, ty = patch_coordinate(hr_hw[1], w)[None, :, None], patch_coordinate(hr_hw[0], h)[:, None, None]
    top = values[..., 0:1] + tx * (values[..., 1:2] - values[..., 0:1])
    bottom = values[..., 2:3] + tx * (values[..., 3:4] - values[..., 2:3])
    return (top + ty * (bottom - top)).astype(np.float32)


def detail_correction(raw: np.ndarray, hr_hw, bound: float) -> np.ndarray:
    """The detail patch as the display's YCoCg correction (H, W, 3): (luma, 0, 0), which adds the
    luma to each of R, G and B (``model.ntaau_lr.net.Accumulate``)."""
    luma = detail_luma(raw, hr_hw, bound)
    return np.concatenate([luma, np.zeros_like(luma), np.zeros_like(luma)], axis=-1)


def patch_coordinate(n_hr: int, n_lr: int) -> np.ndarray:
    """Per HR pixel along one axis, ``0.5 + 2 u`` for its offset ``u`` (LR pixels) from its nearest LR
    pixel's centre: the patch's values at -1/4 and +1/4 sit at 0 and 1 (float32, as the torch model)."""
    centre = (np.arange(n_hr, dtype=np.float32) + np.float32(0.5)) * np.float32(n_lr / n_hr)
    u = centre - (nearest_index(n_hr, n_lr).astype(np.float32) + np.float32(0.5))
    return (np.float32(0.5) + np.float32(2.0) * u).astype(np.float32)


def upsample_to_hr(x: np.ndarray, scale, hr_size=None) -> np.ndarray:
    """LR values (h, w, C) bilinearly to HR (clamp-to-edge, texel centres): ``upsample_bilinear`` at
    an integer scale, ``ops.scale.resize_bilinear`` to the HR size ``(W, H)`` at a fractional one."""
    hr_hw = hr_dims(x.shape[:2], scale, hr_size)
    if is_tiled(x.shape[:2], hr_hw, scale):
        return upsample_bilinear(x, int(scale))
    return resize_bilinear(np.asarray(x, np.float32), (hr_hw[1], hr_hw[0]))


def steer_from_lr(raw: np.ndarray, trust_lr: np.ndarray, scale, box_bound: float, filter_bound: float,
                  hr_size=None, floor=0.0) -> Steer:
    """The raw LR steering (h, w, 6; the net's padded output cropped) and the trust map (h, w, 1)
    upsampled bilinearly to HR (clamp-to-edge, texel centres) and mapped: history gain 2 sigmoid,
    its part above 1 scaled by the trust; sample gain 2 sigmoid; box widening, a widening scaled by
    the trust; fallback max(tanh, 0); the display filter's weights ``filter_bound`` tanh.  The
    history gain after the trust gate is at least ``floor`` (``ops.taau.history_floor``, (H, W, 1)
    or a scalar)."""
    both = np.concatenate([np.asarray(raw, np.float32), np.asarray(trust_lr, np.float32)], axis=-1)
    hr = upsample_to_hr(both, scale, hr_size)
    allowed = hr[..., 6:7]
    sigmoid = lambda x: 1.0 / (1.0 + np.exp(-np.clip(x, -80.0, 80.0)))  # noqa: E731  (no overflow; same values)
    history_gain = 2.0 * sigmoid(hr[..., 0:1])
    history_gain = np.where(history_gain > 1.0, 1.0 + (history_gain - 1.0) * allowed, history_gain)
    history_gain = np.maximum(history_gain, np.asarray(floor, np.float32))
    widen = box_widening(hr[..., 2:3], box_bound)
    widen = np.where(widen > 0.0, widen * allowed, widen)
    bound = np.float32(filter_bound)
    return Steer(history_gain=history_gain.astype(np.float32), sample_gain=(2.0 * sigmoid(hr[..., 1:2])).astype(np.float32),
                 box_widen=widen.astype(np.float32), fallback=np.maximum(np.tanh(hr[..., 3:4]), 0.0).astype(np.float32),
                 filter_axis=(bound * np.tanh(hr[..., 4:5])).astype(np.float32),
                 filter_diagonal=(bound * np.tanh(hr[..., 5:6])).astype(np.float32))


def filter_weights(raw: np.ndarray, scale, filter_bound: float, hr_size=None) -> tuple[np.ndarray, np.ndarray]:
    """The display filter's axis and diagonal weights (each (H, W, 1)) from the raw LR steering (h, w, 6)."""
    hr = upsample_to_hr(np.asarray(raw, np.float32)[..., 4:6], scale, hr_size)
    bound = np.float32(filter_bound)
    return (bound * np.tanh(hr[..., 0:1])).astype(np.float32), (bound * np.tanh(hr[..., 1:2])).astype(np.float32)

