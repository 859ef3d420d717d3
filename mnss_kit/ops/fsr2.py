"""Reference FSR2-class temporal upscaler (numpy, one frame, ``(H, W, C)``): the definition the
``fsr2`` baseline (``eval.baselines.FSR2``) runs and the ``fsr2_*`` GPU passes follow.

Written from the published description of AMD FidelityFX Super Resolution 2 (GPUOpen's FSR 2
documentation), not from its source; the steps and their names follow that description, the
formulas are this toolkit's.  Per frame, LR inputs colour (jittered, display values), depth
(canonical: linear, [0, 1], larger is farther) and motion (LR pixels, unjittered, pointing to the
previous frame; ``ops.conventions``), state the HR history and the HR lock status:

1. Reconstruct and dilate (``dilate``, ``reconstruct_previous_depth``; GPU ``fsr2_reconstruct_pass``).
   Each LR pixel takes the depth and motion of the nearest surface in its 3x3 neighbourhood when
   that surface is nearer by more than ``dilation_edge`` of the pixel's depth (across an edge, so
   thin foreground edges carry their own motion; not along a slope, whose nearer neighbour is the
   same surface moving differently).  The dilated depth is scattered along the dilated motion
   into the previous frame (the four texels of the bilinear footprint, the nearest depth wins):
   an estimate of the previous frame's depth that needs no depth history.
2. Depth clip (``disocclusion``; GPU ``fsr2_depth_clip_pass``).  Where this frame's surface lies
   behind the reconstructed previous depth at its previous position by more than a tolerance
   (``depth_tolerance`` of its depth plus ``slope_factor`` times the surface's own depth step),
   something in front covered it last frame: the history there is of another surface, and its
   weight is cut.  The same pass marks thin features (``thin_features``): LR pixels whose luma is
   a strict local extreme across a row or column by at least ``lock_contrast``.
3. Lock (``update_locks``, in ``accumulate``).  A thin feature locks the HR pixel its sample lands
   in: for ``lock_frames`` frames the history there is trusted past the colour clamp (which would
   erase a one-pixel line the LR frame only sometimes sees).  Locks move with the history; a
   disocclusion removes them, and so does luma instability: a new sample on a locked pixel whose
   luma differs from the locked luma by more than ``lock_luma_tolerance``.
4. Accumulate (``accumulate``; GPU ``fsr2_accumulate_pass``).  This frame's samples reach each HR
   pixel through the main lobe of a Lanczos-2 kernel on their distance in HR pixels (scaled by
   the kernel's width, FSR 2's footprint unless ``kernel_width`` is set), whose total is their
   weight in the blend: a sample landing on the pixel centre counts fully.  The history, fetched
   by Catmull-Rom at the position the dilated motion (bilinearly upsampled) gives, is clamped in
   YCoCg to the mean +- ``gamma`` std of the 3x3 LR samples around the nearest one (less where a
   lock holds); its weight (fetched bilinearly) is cut by the fetch's blur (``resample_penalty``),
   the depth clip and the optional reactive mask.  The frame's Lanczos-2 upsampling (exact
   windowed sinc, 4x4 LR taps, deringed to the 2x2 nearest samples) fills in with
   ``prior_weight``, fading as history weight builds up.  The weight accumulates up to
   ``max_weight``; a reset or a surface from off-screen starts it at 0.
5. RCAS (``rcas``; GPU ``fsr2_rcas_pass``), optional.  Robust contrast-adaptive sharpening of the
   output (not of the history): a negative-lobe cross filter whose lobe is the strongest that
   cannot push the pixel outside [0, 1] given its four neighbours' extremes, capped and scaled by
   ``sharpness``.

Pixel centres at +0.5, clamp-to-edge texel indices, jitter ``(2,)`` in LR pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .taau import nearest_up, rgb_to_ycocg, ycocg_to_rgb
from .resample import bilinear_sample
from .sanitize import sanitize_colour, sanitize_depth, sanitize_motion
from .warp import upsample_motion

NO_DEPTH = np.float32(1.0)  # reconstructed previous depth where no surface landed: the far plane, never a clip
RCAS_LOBE_LIMIT = np.float32(0.1875)  # the strongest lobe: taps -0.75 around a centre of 4 (they sum to 1)
PRIOR_FADE = np.float32(3.0)  # the prior's weight falls by e^-3 per unit of history weight
LUMA = np.array([0.25, 0.5, 0.25], np.float32)  # YCoCg's Y
KERNEL_BIAS_MAX = 1.99  # FSR 2's cap on the factor that maps LR offsets onto its kernel


@dataclass(frozen=True)
class FSR2Params:
    """The upscaler's knobs (display-value colour, canonical depth)."""

    max_weight: float = 12.0  # history weight cap: about that many frames of full samples
    gamma: float = 3.0  # clamp box half-width in standard deviations of the 3x3 samples
    resample_penalty: float = 1.0  # history weight lost per unit of the fetch's blur (sum over axes of t (1 - t))
    kernel_width: float | None = None  # HR pixels from a sample to its kernel's first zero; None: FSR2's (kernel_width_at)
    prior_weight: float = 0.1  # weight of the Lanczos-upsampled frame where the history is empty (PRIOR_FADE)
    dilation_edge: float = 0.05  # a neighbour this much nearer (relative) is across an edge: dilate to it
    depth_tolerance: float = 0.02  # relative depth separation that starts a depth clip
    slope_factor: float = 2.0  # plus this many times the surface's depth step per LR pixel
    lock_contrast: float = 0.04  # luma step on both sides that makes a thin feature
    lock_frames: int = 8  # frames a lock holds without being renewed
    lock_luma_tolerance: float = 0.1  # luma change that breaks a lock
    sharpness: float = 0.0  # RCAS strength in [0, 1]; 0 leaves the output unsharpened

    def __post_init__(self):
        if not 0.0 <= self.sharpness <= 1.0:
            raise ValueError(f"sharpness must be in [0, 1], got {self.sharpness}")
        if self.max_weight <= 0 or self.lock_frames < 1:
            raise ValueError("max_weight must be positive and lock_frames at least 1")
        if self.kernel_width is not None and self.kernel_width <= 0:
            raise ValueError(f"kernel_width must be positive, got {self.kernel_width}")

    def kernel_width_at(self, scale: int) -> float:
        """The kernel's first zero in HR pixels at ``scale``.  FSR 2 evaluates Lanczos-2 on a
        sample's LR offset times ``min(1.99, scale)``, so its first zero lies ``scale / min(1.99,
        scale)`` HR pixels away: about one HR pixel at x2, a footprint of two output pixels across."""
        if self.kernel_width is not None:
            return float(self.kernel_width)
        return float(np.float32(scale) / np.float32(min(KERNEL_BIAS_MAX, scale)))


@dataclass
class FSR2State:
    """What carries to the next frame: ``history`` (H, W, 4) the output RGB and its accumulated
    weight, ``locks`` (H, W, 2) each pixel's lock lifetime in [0, 1] and the luma it locked."""

    history: np.ndarray
    locks: np.ndarray

    @classmethod
    def empty(cls, hr_height: int, hr_width: int) -> "FSR2State":
        return cls(np.zeros((hr_height, hr_width, 4), np.float32), np.zeros((hr_height, hr_width, 2), np.float32))


def luma(rgb: np.ndarray) -> np.ndarray:
    """``(..., 1)`` YCoCg luma of RGB ``(..., 3)``."""
    return (np.asarray(rgb, np.float32) @ LUMA)[..., None]


def _neighbours(x: np.ndarray):
    """The 3x3 clamp-to-edge neighbourhood of ``x`` (h, w, C), in scan order (dy, then dx, from -1)."""
    h, w = x.shape[:2]
    p = np.pad(x, ((1, 1), (1, 1), (0, 0)), mode="edge")
    return [p[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w] for dy in (-1, 0, 1) for dx in (-1, 0, 1)]


# -- 1. reconstruct and dilate ------------------------------------------------------------------
def dilate(depth: np.ndarray, motion: np.ndarray, edge: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-depth 3x3 dilation: ``depth`` (h, w, 1) and ``motion`` (h, w, 2) of the nearest
    (smallest-depth) neighbour, the first in scan order on a tie, where it is nearer than the
    pixel's own depth by more than ``edge`` times that depth (an edge, not a slope); float32."""
    depths = _neighbours(np.asarray(depth, np.float32))
    motions = _neighbours(np.asarray(motion, np.float32))
    best_depth, best_motion = depths[0].copy(), motions[0].copy()
    for d, m in zip(depths[1:], motions[1:]):
        nearer = d < best_depth
        best_depth = np.where(nearer, d, best_depth)
        best_motion = np.where(nearer, m, best_motion)
    centre = depths[4]
    slope = centre - best_depth <= np.float32(edge) * centre
    return np.where(slope, centre, best_depth), np.where(slope, motions[4], best_motion)


def encode_depth(depth) -> np.ndarray:
    """Depth as the float32 the GPU's ``atomicMax`` on its bits keeps the nearest of: ``2 - depth``
    lies in [1, 2], where larger floats have larger bits; 0 (a cleared buffer) means no surface."""
    return np.float32(2.0) - np.asarray(depth, np.float32)


def decode_depth(encoded: np.ndarray) -> np.ndarray:
    encoded = np.asarray(encoded, np.float32)
    return np.where(encoded > 0, np.float32(2.0) - encoded, NO_DEPTH).astype(np.float32)


def scatter_targets(dilated_motion: np.ndarray):
    """Where each LR pixel's surface lands in the previous frame: the four texels ``(rows, cols)``
    of its bilinear footprint, each ``(4, h, w)`` int64, and whether each receives it (on screen,
    bilinear weight above zero)."""
    h, w = dilated_motion.shape[:2]
    y, x = np.meshgrid(np.arange(h, dtype=np.float32) + 0.5, np.arange(w, dtype=np.float32) + 0.5, indexing="ij")
    fx = x + dilated_motion[..., 0] - np.float32(0.5)
    fy = y + dilated_motion[..., 1] - np.float32(0.5)
    bx, by = np.floor(fx), np.floor(fy)
    tx, ty = fx - bx, fy - by
    rows, cols, receives = [], [], []
    for oy, wy in ((0, 1.0 - ty), (1, ty)):
        for ox, wx in ((0, 1.0 - tx), (1, tx)):
            r, c = by + oy, bx + ox
            receives.append((wy * wx > 0) & (r >= 0) & (r < h) & (c >= 0) & (c < w))
            rows.append(np.clip(r, 0, h - 1).astype(np.int64))
            cols.append(np.clip(c, 0, w - 1).astype(np.int64))
    return np.stack(rows), np.stack(cols), np.stack(receives)


def reconstruct_previous_depth_encoded(dilated_depth: np.ndarray, dilated_motion: np.ndarray) -> np.ndarray:
    """(h, w) float32: the largest ``encode_depth`` scattered to each previous-frame texel, 0 where
    none landed (what the GPU's buffer holds after ``fsr2_reconstruct_pass``)."""
    h, w = dilated_depth.shape[:2]
    rows, cols, receives = scatter_targets(np.asarray(dilated_motion, np.float32))
    encoded = np.broadcast_to(encode_depth(dilated_depth[..., 0]), rows.shape)
    out = np.zeros(h * w, np.float32)
    np.maximum.at(out, (rows * w + cols)[receives], encoded[receives])
    return out.reshape(h, w)


def reconstruct_previous_depth(dilated_depth: np.ndarray, dilated_motion: np.ndarray) -> np.ndarray:
    """(h, w, 1): the previous frame's depth estimated from this frame's, ``NO_DEPTH`` where no surface landed."""
    return decode_depth(reconstruct_previous_depth_encoded(dilated_depth, dilated_motion))[..., None]


# -- 2. depth clip and thin features ------------------------------------------------------------
def depth_slope(dilated_depth: np.ndarray) -> np.ndarray:
    """(h, w, 1): the surface's depth step per LR pixel, the larger over the two axes of the
    smaller one-sided difference (a silhouette has a same-surface side, a slope has none flat)."""
    n = _neighbours(np.asarray(dilated_depth, np.float32))
    centre = n[4]
    across_x = np.minimum(np.abs(centre - n[3]), np.abs(centre - n[5]))
    across_y = np.minimum(np.abs(centre - n[1]), np.abs(centre - n[7]))
    return np.maximum(across_x, across_y)


def disocclusion(dilated_depth: np.ndarray, dilated_motion: np.ndarray, previous_depth: np.ndarray,
                 params: FSR2Params) -> np.ndarray:
    """(h, w, 1) in [0, 1]: how surely each LR pixel's surface was hidden last frame.  Per texel of
    the bilinear footprint at its previous position, the separation ``depth - previous`` beyond the
    tolerance ``depth_tolerance * depth + slope_factor * slope``, in units of that tolerance,
    clamped to [0, 1]; the footprint's bilinear mix of those (off-screen texels count as clamped)."""
    h, w = dilated_depth.shape[:2]
    d = np.asarray(dilated_depth, np.float32)[..., 0]
    tolerance = np.float32(params.depth_tolerance) * d + np.float32(params.slope_factor) * depth_slope(dilated_depth)[..., 0]
    tolerance = np.maximum(tolerance, np.float32(1e-6))
    y, x = np.meshgrid(np.arange(h, dtype=np.float32) + 0.5, np.arange(w, dtype=np.float32) + 0.5, indexing="ij")
    fx = x + dilated_motion[..., 0] - np.float32(0.5)
    fy = y + dilated_motion[..., 1] - np.float32(0.5)
    bx, by = np.floor(fx), np.floor(fy)
    tx, ty = fx - bx, fy - by
    prev = previous_depth[..., 0]
    clip = np.zeros((h, w), np.float32)
    for oy, wy in ((0, 1.0 - ty), (1, ty)):
        for ox, wx in ((0, 1.0 - tx), (1, tx)):
            r = np.clip(by + oy, 0, h - 1).astype(np.int64)
            c = np.clip(bx + ox, 0, w - 1).astype(np.int64)
            clip += (wy * wx) * np.clip((d - prev[r, c] - tolerance) / tolerance, 0.0, 1.0)
    return clip[..., None].astype(np.float32)


def thin_features(colour: np.ndarray, lock_contrast: float) -> np.ndarray:
    """(h, w, 1) 1.0 where an LR pixel's luma is above or below both its row neighbours, or both its
    column neighbours, by at least ``lock_contrast`` (clamp-to-edge), else 0.0."""
    n = _neighbours(luma(colour))
    c, t = n[4], np.float32(lock_contrast)

    def ridge(a, b):
        return ((c - a >= t) & (c - b >= t)) | ((a - c >= t) & (b - c >= t))

    return (ridge(n[3], n[5]) | ridge(n[1], n[7])).astype(np.float32)


# -- 4. accumulate --------------------------------------------------------------------------------
def lanczos2(x) -> np.ndarray:
    """The Lanczos-2 kernel ``sinc(x) sinc(x / 2)`` for |x| < 2, else 0 (float32)."""
    x = np.asarray(x, np.float64)
    return np.where(np.abs(x) < 2.0, np.sinc(x) * np.sinc(x / 2.0), 0.0).astype(np.float32)


def catmull_rom_weights(t: np.ndarray) -> np.ndarray:
    """``(..., 4)`` Catmull-Rom weights of the taps at -1, 0, 1, 2 for the fractional position ``t``."""
    t = np.asarray(t, np.float32)
    t2, t3 = t * t, t * t * t
    return np.stack([-0.5 * t + t2 - 0.5 * t3, 1.0 - 2.5 * t2 + 1.5 * t3, 0.5 * t + 2.0 * t2 - 1.5 * t3,
                     -0.5 * t2 + 0.5 * t3], axis=-1).astype(np.float32)


def _sample_axis(n_lr: int, scale: int, shift: float):
    """Per HR index along one axis: the LR sample coordinate ``u``, the nearest sample's index and
    its distance to the pixel centre (HR pixels)."""
    centre = np.arange(n_lr * scale, dtype=np.float32) + np.float32(0.5)
    u = centre / np.float32(scale) - np.float32(shift)
    nearest = np.clip(np.floor(u), 0, n_lr - 1).astype(np.int64)
    distance = centre - np.float32(scale) * (nearest.astype(np.float32) + np.float32(0.5) + np.float32(shift))
    return u, nearest, distance


def lanczos_upsample(current: np.ndarray, jitter, scale: int) -> np.ndarray:
    """The Lanczos-2 upsampling ``(H, W, C)`` of ``current`` (h, w, C) with each sample where it was
    shaded (kernel in LR pixels, 4x4 taps, weights normalised, clamp-to-edge), deringed: clamped to
    the min and max of the 2x2 nearest samples.  The frame's estimate where no sample is near."""
    h, w = current.shape[:2]
    jx, jy = (float(v) for v in np.asarray(jitter, np.float32).reshape(2))
    axes = []
    for n_lr, shift in ((h, jy), (w, jx)):
        u = _sample_axis(n_lr, scale, shift)[0]
        base = np.floor(u - np.float32(0.5))
        index = np.clip(base[:, None].astype(np.int64) + np.arange(-1, 3), 0, n_lr - 1)
        weights = lanczos2((u - np.float32(0.5) - base)[:, None] - np.arange(-1, 3, dtype=np.float32))
        axes.append((index, weights / weights.sum(axis=1, keepdims=True)))
    (rows, wy), (cols, wx) = axes
    # separable: along x at LR rows, then along y (the sums in another order than the shader's 4x4)
    across = sum(wx[None, :, b, None] * current[:, cols[:, b]] for b in range(4))
    out = sum(wy[:, a, None, None] * across[rows[:, a]] for a in range(4))
    near_x = [np.minimum(current[:, cols[:, 1]], current[:, cols[:, 2]]), np.maximum(current[:, cols[:, 1]], current[:, cols[:, 2]])]
    lo = np.minimum(near_x[0][rows[:, 1]], near_x[0][rows[:, 2]])
    hi = np.maximum(near_x[1][rows[:, 1]], near_x[1][rows[:, 2]])
    return np.clip(out, lo, hi).astype(np.float32)


def reconstruct_samples(current: np.ndarray, jitter, scale: int, kernel_width: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """This frame's samples at each HR pixel: the mean ``(H, W, C)`` of the 3x3 LR samples around the
    nearest one weighted by the main lobe of Lanczos-2 on their distance to the pixel centre in HR
    pixels over ``kernel_width`` (the negative lobes would let samples beyond the pixel subtract),
    and the total weight ``(H, W, 1)``: 1 where a sample landed on the pixel centre, 0 where none
    came within ``kernel_width`` (the mean is then the nearest sample's value)."""
    h, w = current.shape[:2]
    jx, jy = (float(v) for v in np.asarray(jitter, np.float32).reshape(2))
    axes = []
    for n_lr, shift in ((h, jy), (w, jx)):
        _, nearest, distance = _sample_axis(n_lr, scale, shift)
        index = np.clip(nearest[:, None] + np.arange(-1, 2), 0, n_lr - 1)
        offsets = (distance[:, None] - np.float32(scale) * np.arange(-1, 2, dtype=np.float32)) / np.float32(kernel_width)
        axes.append((index, np.where(np.abs(offsets) < 1.0, lanczos2(offsets), np.float32(0.0))))
    (rows, wy), (cols, wx) = axes
    across = sum(wx[None, :, b, None] * current[:, cols[:, b]] for b in range(3))  # separable, as above
    acc = sum(wy[:, a, None, None] * across[rows[:, a]] for a in range(3))
    total = (wy.sum(axis=1)[:, None] * wx.sum(axis=1)[None, :])[..., None]
    nearest = current[rows[:, 1]][:, cols[:, 1]]
    return np.where(total > 0, acc / np.where(total > 0, total, np.float32(1.0)), nearest).astype(np.float32), total


def nearest_sample_index(h: int, w: int, jitter, scale: int) -> tuple[np.ndarray, np.ndarray]:
    """Per HR row and column, the index of the LR sample nearest to the pixel centre: ``(H,)``, ``(W,)``."""
    jx, jy = (float(v) for v in np.asarray(jitter, np.float32).reshape(2))
    return _sample_axis(h, scale, jy)[1], _sample_axis(w, scale, jx)[1]


def sample_owner(h: int, w: int, jitter, scale: int) -> np.ndarray:
    """(H, W) bool: the HR pixels a sample landed in (one per LR pixel)."""
    jx, jy = (float(v) for v in np.asarray(jitter, np.float32).reshape(2))
    owned = []
    for n_lr, shift in ((h, jy), (w, jx)):
        _, nearest, _ = _sample_axis(n_lr, scale, shift)
        position = np.float32(scale) * (nearest.astype(np.float32) + np.float32(0.5) + np.float32(shift))
        owned.append(np.floor(position).astype(np.int64) == np.arange(n_lr * scale))
    return owned[0][:, None] & owned[1][None, :]


def variance_box(current: np.ndarray, rows: np.ndarray, cols: np.ndarray, gamma: float):
    """The clamp box ``(lo, hi)``, each ``(H, W, C)``: mean +- ``gamma`` std of the 3x3 LR samples
    around the sample at ``(rows[y], cols[x])``."""
    window = np.stack(_neighbours(current))
    mean = window.mean(axis=0)
    std = np.sqrt(np.maximum((window * window).mean(axis=0) - mean * mean, 0.0))
    mean, std = mean[rows][:, cols], std[rows][:, cols]
    return mean - np.float32(gamma) * std, mean + np.float32(gamma) * std


def reproject(history: np.ndarray, locks: np.ndarray, dilated_motion: np.ndarray, scale: int, reset: bool):
    """The state warped to this frame by the dilated motion, bilinearly upsampled (``ops.warp``; the
    LR cell's own motion would be off by up to half an LR pixel's motion gradient): the history
    colour (Catmull-Rom, clamp-to-edge, YCoCg) ``(H, W, 3)``, its weight ``(H, W, 1)`` (bilinear)
    and the locks ``(H, W, 2)`` (nearest texel); weight and locks zero after a reset and where the surface
    was off-screen."""
    hh, hw = history.shape[:2]
    motion = upsample_motion(np.asarray(dilated_motion, np.float32), scale)
    y, x = np.meshgrid(np.arange(hh, dtype=np.float32) + 0.5, np.arange(hw, dtype=np.float32) + 0.5, indexing="ij")
    px, py = x + motion[..., 0], y + motion[..., 1]
    keep = ((px >= 0) & (px < hw) & (py >= 0) & (py < hh) & (not reset))[..., None]
    fx, fy = px - np.float32(0.5), py - np.float32(0.5)
    bx, by = np.floor(fx), np.floor(fy)
    wx, wy = catmull_rom_weights(fx - bx), catmull_rom_weights(fy - by)
    bx = np.clip(bx, -2, hw).astype(np.int64)  # far off-screen positions stay defined (their weight is 0)
    by = np.clip(by, -2, hh).astype(np.int64)
    flat = np.ascontiguousarray(history[..., :3]).reshape(hh * hw, 3)  # flat gathers: much faster than 2-D indexing
    colour = np.zeros((hh, hw, 3), np.float32)
    for a in range(4):
        r = np.clip(by + a - 1, 0, hh - 1) * hw
        for b in range(4):
            c = np.clip(bx + b - 1, 0, hw - 1)
            colour += (wy[..., a] * wx[..., b])[..., None] * np.take(flat, r + c, axis=0)
    nr = np.clip(np.floor(py), 0, hh - 1).astype(np.int64)
    nc = np.clip(np.floor(px), 0, hw - 1).astype(np.int64)
    tx, ty = fx - np.floor(fx), fy - np.floor(fy)
    spread = (tx * (1.0 - tx) + ty * (1.0 - ty))[..., None]
    weight = bilinear_sample(history[..., 3:4], px, py)  # spread like the colour: MNSS hits are one pixel in four
    return rgb_to_ycocg(colour), weight * keep, locks[nr, nc] * keep, spread


def accumulate(colour: np.ndarray, dilated_motion: np.ndarray, analysis: np.ndarray, history: np.ndarray,
               locks: np.ndarray, jitter, scale: int, reset: bool, params: FSR2Params,
               reactive: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One frame's blend.  ``colour`` (h, w, 3) RGB, ``dilated_motion`` (h, w, 2), ``analysis``
    (h, w, 2) the disocclusion and thin-feature mask, ``history`` (H, W, 4) and ``locks`` (H, W, 2)
    the previous state, ``reactive`` (h, w, 1) in [0, 1] or None.  Returns the next history (the
    output RGB in [0, 1] and its weight) and the next locks."""
    h, w = colour.shape[:2]
    current = rgb_to_ycocg(colour)
    samples, sample_weight = reconstruct_samples(current, jitter, scale, params.kernel_width_at(scale))
    upsampled = lanczos_upsample(current, jitter, scale)
    rows, cols = nearest_sample_index(h, w, jitter, scale)
    lo, hi = variance_box(current, rows, cols, params.gamma)
    previous, weight, lock, spread = reproject(history, locks, dilated_motion, scale, reset)
    weight = weight * np.maximum(1.0 - np.float32(params.resample_penalty) * spread, 0.0)

    disoccluded = nearest_up(analysis[..., 0:1], scale)
    reactive = 0.0 if reactive is None else nearest_up(np.asarray(reactive, np.float32), scale)
    lifetime, locked_luma = update_locks(lock, samples[..., 0:1], disoccluded, analysis[..., 1:2], rows, cols,
                                         sample_owner(h, w, jitter, scale)[..., None], params)
    trust = lifetime * (1.0 - disoccluded)
    clamped = np.minimum(np.maximum(previous, lo), hi)
    previous = clamped + trust * (previous - clamped)
    weight = weight * (1.0 - disoccluded) * (1.0 - reactive)
    prior = np.float32(params.prior_weight) * np.exp(-PRIOR_FADE * weight)  # fills what no sample reached yet
    blended = (weight * previous + sample_weight * samples + prior * upsampled) / (weight + sample_weight + prior)
    rgb = np.clip(ycocg_to_rgb(blended), 0.0, 1.0)
    next_weight = np.minimum(weight + sample_weight, np.float32(params.max_weight))
    return (np.concatenate([rgb, next_weight], axis=-1).astype(np.float32),
            np.concatenate([lifetime, locked_luma], axis=-1).astype(np.float32))


def update_locks(lock, sample_luma, disoccluded, thin, rows, cols, owner, params: FSR2Params):
    """The locks after this frame, ``(lifetime, locked luma)`` each ``(H, W, 1)``: the reprojected
    lifetime cut by the disocclusion, dropped where a sample landed with a luma off the locked one,
    aged by ``1 / lock_frames``; a thin feature's sample renews its pixel's lock with its luma."""
    lifetime, locked_luma = lock[..., 0:1], lock[..., 1:2]
    lifetime = lifetime * (1.0 - disoccluded)
    unstable = owner & (np.abs(sample_luma - locked_luma) > np.float32(params.lock_luma_tolerance))
    lifetime = np.where(unstable, 0.0, np.maximum(lifetime - np.float32(1.0 / params.lock_frames), 0.0))
    renew = owner & (thin[rows][:, cols] > 0.5)
    return (np.where(renew, 1.0, lifetime).astype(np.float32),
            np.where(renew, sample_luma, np.where(lifetime > 0, locked_luma, 0.0)).astype(np.float32))


# -- 5. RCAS --------------------------------------------------------------------------------------
def rcas(image: np.ndarray, sharpness: float) -> np.ndarray:
    """Robust contrast-adaptive sharpening of ``image`` (H, W, 3) in [0, 1]: ``(c + w sum(cross)) /
    (1 + 4 w)`` with one negative lobe ``w`` per pixel, the least negative over the channels of the
    bounds that keep the result in [0, 1] whatever the four neighbours' order (``-min / (4 max)``
    and ``(max - 1) / (4 (1 - min))``), at least ``-RCAS_LOBE_LIMIT``, times ``sharpness``."""
    image = np.asarray(image, np.float32)
    if sharpness <= 0.0:
        return image.copy()
    n = _neighbours(image)
    cross = [n[1], n[3], n[5], n[7]]
    lo, hi = np.minimum.reduce(cross), np.maximum.reduce(cross)
    eps = np.float32(1e-6)
    bound = np.maximum(-lo / (4.0 * hi + eps), (hi - 1.0) / (4.0 * (1.0 - lo) + eps))
    lobe = np.maximum(bound.max(axis=-1, keepdims=True), -RCAS_LOBE_LIMIT) * np.float32(sharpness)
    out = (n[4] + lobe * (cross[0] + cross[1] + cross[2] + cross[3])) / (1.0 + 4.0 * lobe)
    return np.clip(out, 0.0, 1.0).astype(np.float32)


# -- one frame ------------------------------------------------------------------------------------
def analyse(colour: np.ndarray, depth: np.ndarray, motion: np.ndarray, params: FSR2Params):
    """Steps 1 and 2 at LR: the dilated motion (h, w, 2) and the analysis (h, w, 2): disocclusion,
    thin-feature mask."""
    dilated_depth, dilated_motion = dilate(depth, motion, params.dilation_edge)
    previous_depth = reconstruct_previous_depth(dilated_depth, dilated_motion)
    clip = disocclusion(dilated_depth, dilated_motion, previous_depth, params)
    return dilated_motion, np.concatenate([clip, thin_features(colour, params.lock_contrast)], axis=-1)


def fsr2_frame(colour, depth, motion, jitter, state: FSR2State | None, scale: int, params: FSR2Params = FSR2Params(),
               reset: bool = False, reactive=None) -> tuple[np.ndarray, FSR2State]:
    """One frame: LR ``colour`` (h, w, 3) display RGB, ``depth`` (h, w, 1), ``motion`` (h, w, 2),
    ``jitter`` (2,) -> the output (H, W, 3) in [0, 1] and the next state; ``state`` None starts a
    sequence (as a reset)."""
    # a NaN or Inf an engine writes costs one frame, never the history (ops.sanitize; the passes
    # sanitize each read of the inputs alike)
    colour, depth, motion = sanitize_colour(colour), sanitize_depth(depth), sanitize_motion(motion)
    h, w = colour.shape[:2]
    if state is None:
        state, reset = FSR2State.empty(h * scale, w * scale), True
    dilated_motion, analysis = analyse(colour, depth, motion, params)
    history, locks = accumulate(np.asarray(colour, np.float32), dilated_motion, analysis, state.history, state.locks,
                                jitter, scale, reset, params, reactive)
    return rcas(history[..., :3], params.sharpness), FSR2State(history, locks)
