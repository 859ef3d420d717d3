"""Neural TAAU: a small network steers the toolkit's TAAU accumulation instead of painting pixels.

Per frame, with scale ``s``, LR size ``h x w`` and HR size ``H x W = sh x sw``
(``model.taau`` defines every step of the accumulation):

    taau_gather      (gpu)  TAAU's inputs: the previous blend and its weight reprojected
                            (bilinear warp, blur undone, zero weight off-screen and after
                            a reset), the Gaussian mean of the nearby jittered samples, the
                            jitter-aware bicubic frame and the 3x3 LR clamp box; and the
                            steering features at LR: the LR colour, the clamped history, its
                            weight / (1/alpha - 1) and the clamp distance (the HR ones
                            pixel-unshuffled)
    steer            (npu)  3x3 convs at LR, pixel shuffle -> 6 (8) raw values per HR pixel
    taau_accumulate  (gpu)  history gain max(2 sigmoid(a), history_gain_min), sample gain
                            2 sigmoid(b), box widening box_bound tanh(c) (narrowing
                            tanh(c) / 2: at most to the box's centre), correction
                            bound * tanh(d) (YCoCg, display only); TAAU's blend with them; with
                            ``filter_bound`` > 0 the displayed blend goes through a 3x3 filter
                            whose axis and diagonal weights are filter_bound * tanh(e), tanh(f)

A fresh net outputs zeros, which is TAAU itself: training starts at the baseline, and the net's
reach beyond it is bounded (a correction of at most ``correction_bound`` per channel, filter
weights of at most ``filter_bound``).  The filter is there because TAAU's blend differs from the
16-sample reference in a way a small filter undoes: one fixed 3x3 filter (blurring along the axes,
sharpening along the diagonals) fitted to TAAU's output on test_x2 raises its PSNR by 0.17 to
0.57 dB per sequence (``scripts/studies/display_filter_fit.py``); the net sets one per pixel.  With
``history_gain_min: 1`` the net cannot trust a history less than TAAU does: it rejects one only
by narrowing the clamp box or by weighting this frame's samples more, as TAAU's own clamp does.

State: ``history`` (N,3,H,W) the previous blend before the correction (RGB; the correction
is for display only, so it cannot build up over frames), ``weight`` (N,1,H,W) its accumulated
sample weight.  A reset frame (camera cut, first frame) gives the history zero weight.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ..blocks import conv_stack
from ..family import check_frame
from ..taau import (TAAUInputs, TAAUParams, blend, filter_gain, history_floor, sanitize_colour, sanitize_motion,
                    start_frame, steer_from_raw, taau_inputs)
from .config import NTAAUConfig

STAGE_ORDER = ("taau_gather", "steer", "taau_accumulate")
FRAME_SHAPES = {"color": 3, "motion": 2}


class Gather(nn.Module):
    """TAAU's inputs and the steering features (no weights)."""

    placement = "gpu"

    def __init__(self, scale: int, params: TAAUParams):
        super().__init__()
        self.scale, self.params = scale, params

    def forward(self, color, jitter, motion, reset, state):
        """-> (TAAUInputs, features (N, 3 + 5 s^2, h, w))."""
        inputs = taau_inputs(color, jitter, motion, reset, state, self.scale, self.params)
        clamped = torch.minimum(torch.maximum(inputs.history, inputs.lo), inputs.hi)
        distance = (inputs.history - clamped).abs().sum(dim=1, keepdim=True)
        weight = inputs.history_weight / self.params.max_weight
        hr = torch.cat([clamped, weight, distance], dim=1)
        return inputs, torch.cat([color, F.pixel_unshuffle(hr, self.scale)], dim=1)


class SteerNet(nn.Module):
    """The NPU part: Conv2d (bias), ReLU, PixelShuffle; fx-traceable.

    ``forward(features)``: (N, 3 + 5 s^2, h, w) -> raw steering (N, 6 or 8, H, W)."""

    placement = "npu"

    def __init__(self, scale: int, c_in: int, width: int, layers: int, c_out: int):
        super().__init__()
        self.body = conv_stack(c_in, width, layers, c_out * scale * scale)
        self.shuffle = nn.PixelShuffle(scale)

    def forward(self, features):
        return self.shuffle(self.body(features))


class Accumulate(nn.Module):
    """The raw steering mapped to its ranges, and TAAU's blend with it."""

    placement = "gpu"

    def __init__(self, params: TAAUParams, config: NTAAUConfig):
        super().__init__()
        self.params, self.config = params, config

    def forward(self, inputs: TAAUInputs, raw):
        c = self.config
        floor = history_floor(inputs.hr_motion, c.history_gain_min, c.still_motion_px)
        fade = filter_gain(inputs.hr_motion, c.filter_falloff)
        return blend(inputs, self.params, steer_from_raw(raw, c.correction_bound, floor, c.filter_bound, c.box_bound, fade))


class NTAAU(nn.Module):
    """``model(frame, state) -> (output, aux, state)``; see the module docstring and docs/architecture.md."""

    def __init__(self, config: NTAAUConfig):
        super().__init__()
        self.config = config
        self.scale = s = config.scale
        self.params = TAAUParams(alpha=config.alpha)
        self.taau_gather = Gather(s, self.params)
        self.steer = SteerNet(s, config.npu_input_channels(), config.width, config.layers, config.steer_channels())
        self.taau_accumulate = Accumulate(self.params, config)

    def stages(self) -> list[tuple[str, nn.Module, str]]:
        return [(n, getattr(self, n), getattr(self, n).placement) for n in STAGE_ORDER]

    def initial_state(self, frame: dict) -> dict:
        color = frame["color"]
        n, _, h, w = color.shape
        return {"history": color.new_zeros(n, 3, h * self.scale, w * self.scale),
                "weight": color.new_zeros(n, 1, h * self.scale, w * self.scale)}

    def forward(self, frame: dict, state: dict | None = None):
        """One frame: color (N,3,h,w), motion (N,2,h,w), jitter (N,2), optional reset (N,).
        Returns output (N,3,H,W), aux {taau: the unsteered blend of the same inputs}, next state."""
        check_frame(frame, FRAME_SHAPES, self.scale, "ntaau")
        # one bad frame costs one frame: NaN / Inf inputs never reach the history (ops.sanitize)
        color, motion, jitter = sanitize_colour(frame["color"]), sanitize_motion(frame["motion"]), frame["jitter"]
        # reset (N,), cut (N, 1, 1, 1): a cut history may hold anything, NaN included
        reset, cut, state = start_frame(frame, state, self.initial_state, color)
        state = {k: torch.where(cut, 0.0, v) for k, v in state.items()}
        inputs, features = self.taau_gather(color, jitter, motion, reset, state)
        output, next_state = self.taau_accumulate(inputs, self.steer(features))
        with torch.no_grad():
            taau, _ = blend(inputs, self.params)
        return output, {"taau": taau}, next_state
