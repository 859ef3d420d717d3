"""Neural TAAU steered at LR: a small encoder-decoder at LR reads what the GPU can cheaply tell
about each pixel's history and steers the toolkit's TAAU accumulation, with a way out of it.

Per frame, with scale ``s``, LR size ``h x w`` and HR size ``H x W = sh x sw`` (at a fractional
scale such as 1.5 or 1.7, ``round_half_up(s h) x round_half_up(s w)`` or the data's HR size, each
HR pixel mapped to LR by the exact per-axis ratio; ``model.taau`` defines every step of the
accumulation):

    lr_gather   (gpu)  TAAU's inputs (``model.taau.taau_inputs``) and 8 features per LR pixel:
                       the LR colour, the clamped history's luma minus the colour's, the clamp
                       distance and the history weight (each averaged over the pixel's s x s HR
                       block), the depth change since the last frame (this depth against the
                       nearest of the last frame's 3x3 depths at the reprojected position,
                       relative) and the motion spread (largest motion difference to a 3x3
                       neighbour, LR pixels); padded to an even size
    steer       (npu)  conv 3x3 at LR, space-to-depth, ``mid_layers`` convs 3x3 at half LR,
                       conv 1x1, depth-to-space, added to the first conv's output, conv 3x3:
                       6 raw values per LR pixel (1.5 bytes per HR pixel at x2 in int8)
    lr_accumulate (gpu) the raw values upsampled bilinearly to HR and mapped to the steering:
                       history gain 2 sigmoid(a) (trust-gated, then at least
                       ``model.taau.history_floor``), sample gain 2 sigmoid(b), box widening
                       (``model.taau.box_widening``), spatial fallback max(tanh(d), 0) and the
                       display filter's weights filter_bound tanh(e), tanh(f); TAAU's blend
                       with them

With ``model.detail`` (integer scales) the NPU input also holds the clamped history's luma at each
of the s x s HR pixels of an LR pixel, a branch beside the steering (three convs or an
encoder-decoder, reading those or every input: ``detail_form``, ``detail_reads``) turns them into
4 more raw values per LR pixel, and lr_accumulate adds their luma patch (``detail_luma``) to the
display, never to the history.

Trust is earned from evidence: the part of the history gain above 1 and a widening of the box
are scaled by ``trust = clamp(1 - max(depth change, 0) / trust_depth - spread / trust_spread_px,
0, 1)``, so where depth says "disoccluded" or the motion field says "edge of a moving object" the
net cannot trust a history more than TAAU does.  It can always trust it less, and move the blend
towards a spatial reconstruction of this frame's samples (the jitter-aware bicubic), which also
drops the accumulated weight: alpha-tested cut-outs, disocclusions and a settling pan, where
TAAU's history is wrong, get this frame instead of TAAU's failures.

A fresh net outputs zeros, which is TAAU itself.  State: ``history`` (N,3,H,W) the previous
blend, ``weight`` (N,1,H,W) its accumulated weight, ``depth`` (N,1,h,w) the last LR depth.
"""

from __future__ import annotations

import contextlib
import copy

import torch
import torch.nn.functional as F
from torch import nn

from ..family import check_frame
from ..layers import warp_bilinear
from ..taau import (Steer, TAAUInputs, TAAUParams, blend, block_mean, box_widening, history_floor, hr_dims, is_tiled,
                    nearest_index, rgb_to_ycocg, sanitize_colour, sanitize_depth, sanitize_motion,
                    start_frame, taau_inputs)
from ...ops.scale import parse_scale, size_mismatch
from .config import DETAIL_CHANNELS, STEER_CHANNELS, NTAAULRConfig

STAGE_ORDER = ("lr_gather", "steer", "lr_accumulate")
FRAME_SHAPES = {"color": 3, "depth": 1, "motion": 2}
DEPTH_FLOOR = 1e-4  # canonical depth below which the relative change is taken against this


def depth_change(depth: torch.Tensor, previous: torch.Tensor, motion: torch.Tensor) -> torch.Tensor:
    """Relative depth change per LR pixel (N, 1, h, w): this depth minus the nearest of the last
    frame's 3x3 depths around where the pixel was, over this depth; > 0 where a surface appeared
    from behind another (a disocclusion).  The nearest of 3x3 keeps thin foreground edges, which a
    fractional fetch would blur into the background, from reading as disocclusions."""
    nearest = -F.max_pool2d(F.pad(-previous, (1, 1, 1, 1), mode="replicate"), 3, stride=1)
    reprojected = warp_bilinear(nearest, motion)
    return ((depth - reprojected) / depth.clamp(min=DEPTH_FLOOR)).clamp(-1.0, 1.0)


def motion_spread(motion: torch.Tensor) -> torch.Tensor:
    """Largest L1 difference (LR pixels) between a pixel's motion and one of its 8 neighbours' (N, 1, h, w)."""
    h, w = motion.shape[-2:]
    p = F.pad(motion, (1, 1, 1, 1), mode="replicate")
    diffs = [(p[:, :, 1 + dy:1 + dy + h, 1 + dx:1 + dx + w] - motion).abs().sum(dim=1, keepdim=True)
             for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    return torch.stack(diffs, dim=0).amax(dim=0)


def trust(change: torch.Tensor, spread: torch.Tensor, config: NTAAULRConfig) -> torch.Tensor:
    """How much history trust above TAAU's the evidence allows, in [0, 1] per LR pixel."""
    return (1.0 - change.clamp(min=0.0) / config.trust_depth - spread / config.trust_spread_px).clamp(0.0, 1.0)


def pad_even(x: torch.Tensor) -> torch.Tensor:
    """``x`` padded at the bottom and right (edge values) to an even height and width: the steering
    net halves its resolution once."""
    h, w = x.shape[-2:]
    return F.pad(x, (0, w % 2, 0, h % 2), mode="replicate") if (h % 2 or w % 2) else x


class Gather(nn.Module):
    """TAAU's inputs, the trust map and the steering features at LR (no weights)."""

    placement = "gpu"

    def __init__(self, config: NTAAULRConfig, params: TAAUParams):
        super().__init__()
        self.config, self.params = config, params

    def forward(self, color, depth, previous_depth, jitter, motion, reset, state, hr_size=None, scale=None):
        """-> (TAAUInputs, trust (N, 1, h, w), features (N, 8 or 9, h', w') with h', w' the even size).
        The block means are ``model.taau.block_mean`` (``avg_pool2d`` over s x s at an integer scale,
        the HR pixels nearest each LR pixel at a fractional one); ``hr_size`` ``(W, H)`` or None
        (the history's, else ``model.taau.hr_dims``); ``scale`` None: the config's."""
        s = self.config.scale if scale is None else scale
        lr_hw = color.shape[-2:]
        inputs = taau_inputs(color, jitter, motion, reset, state, s, self.params, hr_size)
        clamped = torch.minimum(torch.maximum(inputs.history, inputs.lo), inputs.hi)
        distance = block_mean((inputs.history - clamped).abs().sum(dim=1, keepdim=True), lr_hw, s)
        weight = block_mean(inputs.history_weight, lr_hw, s) / self.params.max_weight
        luma_gap = block_mean(clamped[:, :1], lr_hw, s) - rgb_to_ycocg(color)[:, :1]
        change = depth_change(depth, previous_depth, motion)
        spread = motion_spread(motion)
        parts = [color, luma_gap, distance, weight, change, spread.clamp(max=4.0)]
        if self.config.scale_input:  # 1 / s, a constant map: one checkpoint for several scales
            parts.append(torch.full_like(change, 1.0 / float(s)))
        if self.config.detail:  # the detail branch's input: the clamped history's luma at each of the s x s HR pixels
            parts.append(F.pixel_unshuffle(clamped[:, :1], int(s)))
        features = torch.cat(parts, dim=1)
        return inputs, trust(change, spread, self.config), pad_even(features)


class EncoderDecoder(nn.Module):
    """Conv 3x3 at LR, space-to-depth, ``mid_layers`` convs 3x3 at half LR, conv 1x1, depth-to-space,
    added to the first conv's output, conv 3x3 (its weights zero: a fresh one outputs zeros)."""

    def __init__(self, c_in: int, width: int, mid_layers: int, c_out: int):
        super().__init__()
        self.encode = nn.Sequential(_conv(c_in, width, 3), nn.ReLU())
        mid: list[nn.Module] = [nn.PixelUnshuffle(2)]
        channels = 4 * width
        for _ in range(mid_layers):
            mid += [_conv(channels, 2 * width, 3), nn.ReLU()]
            channels = 2 * width
        mid += [_conv(channels, 4 * width, 1), nn.PixelShuffle(2)]
        self.middle = nn.Sequential(*mid)
        self.decode = nn.Sequential(nn.ReLU(), nn.Conv2d(width, c_out, 3, padding=1))
        nn.init.zeros_(self.decode[1].weight)
        nn.init.zeros_(self.decode[1].bias)

    def forward(self, x):
        encoded = self.encode(x)
        return self.decode(encoded + self.middle(encoded))


def detail_branch(c_in: int, width: int, form: str) -> nn.Module:
    """The detail branch (``model.detail``): ``convs`` three convs 3x3 at LR, or ``unet`` an
    encoder-decoder as the steering's (two convs at half LR), about twice the receptive field; its
    last conv zero, so it draws nothing until trained."""
    if form == "unet":
        return EncoderDecoder(c_in, width, 2, DETAIL_CHANNELS)
    branch = nn.Sequential(_conv(c_in, width, 3), nn.ReLU(), _conv(width, width, 3), nn.ReLU(),
                           nn.Conv2d(width, DETAIL_CHANNELS, 3, padding=1))
    nn.init.zeros_(branch[-1].weight)
    nn.init.zeros_(branch[-1].bias)
    return branch


def _first_conv_path(branch: nn.Module) -> tuple[nn.Sequential, int]:
    """``(container, index)`` of a detail branch's first conv."""
    return (branch.encode, 0) if isinstance(branch, EncoderDecoder) else (branch, 0)


def branch_first_conv(branch: nn.Module) -> nn.Conv2d:
    """A detail branch's first conv (its in_channels: the channels the branch reads)."""
    container, index = _first_conv_path(branch)
    return container[index]


def branch_last_conv(branch: nn.Module) -> nn.Conv2d:
    """A detail branch's last conv (zero: the branch draws nothing)."""
    return branch.decode[-1] if isinstance(branch, EncoderDecoder) else branch[-1]


class SteerNet(EncoderDecoder):
    """The NPU part, an encoder-decoder at LR: Conv2d (bias), ReLU, PixelUnshuffle, PixelShuffle,
    add; fx-traceable.  ``forward(features)``: (N, 8, h, w), h and w even -> raw steering (N, 6, h, w);
    with the detail branch (``model.detail``) the branch reads the inputs after the steering's (or
    all of them: ``model.detail_reads``) and its 4 outputs follow the steering's (exported as
    :class:`FullInputSteerNet`).  A fresh net outputs zeros: TAAU itself."""

    placement = "npu"

    def __init__(self, c_in: int, width: int, mid_layers: int, c_out: int, detail_in: int = 0, detail_width: int = 16,
                 detail_reads_all: bool = False, detail_form: str = "convs"):
        super().__init__(c_in, width, mid_layers, c_out)
        self.c_in = c_in
        # the branch's inputs start at channel 0 (``model.detail_reads`` all) or after the steering's
        self.detail_first = 0 if detail_reads_all else c_in
        if detail_in:
            self.detail = detail_branch(detail_in + (c_in if detail_reads_all else 0), detail_width, detail_form)

    def forward(self, features):
        steering = features[:, :self.c_in] if hasattr(self, "detail") else features
        raw = super().forward(steering)
        if hasattr(self, "detail"):
            raw = torch.cat([raw, self.detail(self.detail_input(features))], dim=1)
        return raw

    def detail_input(self, features: torch.Tensor) -> torch.Tensor:
        """The channels of ``features`` the detail branch reads."""
        return features[:, self.detail_first:]

    def graph_form(self) -> nn.Module:
        """The module the int8 NPU graph is traced from (``quantize.trace``): this net, or with the
        detail branch the same function without slicing its input (the NPU graph has no slice op)."""
        return FullInputSteerNet(self) if hasattr(self, "detail") else self


class FullInputSteerNet(nn.Module):
    """A SteerNet with a detail branch, slice-free: the steering's and the branch's first convs read
    every input channel, with zero weights on the other part's, and the outputs are one concatenation
    (one scale and zero point in int8).  Built from the net's weights when it is exported."""

    def __init__(self, net: SteerNet):
        super().__init__()
        channels = net.detail_first + branch_first_conv(net.detail).in_channels
        self.encode = nn.Sequential(_reading_all(net.encode[0], channels, 0), *net.encode[1:])
        self.middle, self.decode = net.middle, net.decode
        self.detail = copy.deepcopy(net.detail)
        container, index = _first_conv_path(self.detail)
        container[index] = _reading_all(container[index], channels, net.detail_first)

    def forward(self, features):
        return torch.cat([EncoderDecoder.forward(self, features), self.detail(features)], dim=1)


def _reading_all(conv: nn.Conv2d, channels: int, first: int) -> nn.Conv2d:
    """``conv`` over ``channels`` inputs, its own from channel ``first`` on and zero weights on the rest."""
    wide = nn.utils.skip_init(nn.Conv2d, channels, conv.out_channels, conv.kernel_size, padding=conv.padding,
                              device=conv.weight.device, dtype=conv.weight.dtype)  # no draw from the global RNG
    with torch.no_grad():
        wide.weight.zero_()
        wide.weight[:, first:first + conv.in_channels] = conv.weight
        wide.bias.copy_(conv.bias)
    return wide


def _conv(c_in: int, c_out: int, k: int) -> nn.Conv2d:
    conv = nn.Conv2d(c_in, c_out, k, padding=k // 2)
    nn.init.kaiming_normal_(conv.weight, nonlinearity="relu")
    nn.init.zeros_(conv.bias)
    return conv


def steer_from_lr(raw: torch.Tensor, trust_lr: torch.Tensor, config: NTAAULRConfig, hr_size=None,
                  floor: torch.Tensor | float = 0.0) -> Steer:
    """The raw LR steering (N, 6, h, w) and the trust map (N, 1, h, w), upsampled bilinearly to HR
    (clamp-to-edge, texel centres as a GPU's linear filter), mapped to their ranges; the history
    gain after the trust gate at least ``floor`` (``model.taau.history_floor``, (N, 1, H, W) or a
    scalar).  The HR size ``(W, H)``: ``hr_size``, else ``model.taau.hr_dims`` of the scale."""
    s = config.scale
    both = torch.cat([raw, trust_lr], dim=1)
    hr_hw = hr_dims(both.shape[-2:], s, hr_size)
    if is_tiled(both.shape[-2:], hr_hw, s):
        hr = F.interpolate(both, scale_factor=int(s), mode="bilinear", align_corners=False)
    else:
        hr = F.interpolate(both, size=hr_hw, mode="bilinear", align_corners=False)
    allowed = hr[:, 6:7]
    history_gain = 2.0 * torch.sigmoid(hr[:, 0:1])
    history_gain = torch.where(history_gain > 1.0, 1.0 + (history_gain - 1.0) * allowed, history_gain)
    history_gain = torch.maximum(history_gain, torch.as_tensor(floor, dtype=history_gain.dtype))
    widen = box_widening(hr[:, 2:3], config.box_bound)
    widen = torch.where(widen > 0.0, widen * allowed, widen)
    return Steer(history_gain=history_gain, sample_gain=2.0 * torch.sigmoid(hr[:, 1:2]), box_widen=widen,
                 fallback=torch.tanh(hr[:, 3:4]).clamp(min=0.0),
                 filter_axis=config.filter_bound * torch.tanh(hr[:, 4:5]),
                 filter_diagonal=config.filter_bound * torch.tanh(hr[:, 5:6]))


def detail_luma(raw: torch.Tensor, hr_hw: tuple[int, int], bound: float) -> torch.Tensor:
    """The detail patches (N, 4, h, w) drawn at HR (N, 1, H, W): each HR pixel takes its nearest LR
    pixel's patch, bilinear through the patch's four values ``bound tanh(raw)`` placed at offsets
    (-1/4, -1/4), (+1/4, -1/4), (-1/4, +1/4), (+1/4, +1/4) LR pixels from its centre.  At x2 these are
    the four HR pixels' centres, so each HR pixel gets one value (a pixel shuffle); at any other
    scale the patch is interpolated (or extrapolated to +-1/2) at the HR pixel's own offset."""
    h, w = raw.shape[-2:]
    rows, cols = nearest_index(hr_hw[0], h, raw.device), nearest_index(hr_hw[1], w, raw.device)
    values = (bound * torch.tanh(raw)).index_select(2, rows).index_select(3, cols)
    tx = _patch_coordinate(hr_hw[1], w, raw).view(1, 1, 1, -1)
    ty = _patch_coordinate(hr_hw[0], h, raw).view(1, 1, -1, 1)
    top = values[:, 0:1] + tx * (values[:, 1:2] - values[:, 0:1])
    bottom = values[:, 2:3] + tx * (values[:, 3:4] - values[:, 2:3])
    return top + ty * (bottom - top)


def _patch_coordinate(n_hr: int, n_lr: int, like: torch.Tensor) -> torch.Tensor:
    """Per HR pixel along one axis, its offset from its nearest LR pixel's centre mapped so the
    patch's values at -1/4 and +1/4 LR pixels sit at 0 and 1: ``0.5 + 2 u``."""
    centre = (torch.arange(n_hr, dtype=like.dtype, device=like.device) + 0.5) * (n_lr / n_hr)
    u = centre - (nearest_index(n_hr, n_lr, like.device).to(like.dtype) + 0.5)
    return 0.5 + 2.0 * u


class Accumulate(nn.Module):
    """The LR steering upsampled and mapped, and TAAU's blend with it."""

    placement = "gpu"

    def __init__(self, params: TAAUParams, config: NTAAULRConfig):
        super().__init__()
        self.params, self.config = params, config

    def forward(self, inputs: TAAUInputs, trust_lr, raw):
        h, w = trust_lr.shape[-2:]
        hr_size = (inputs.samples.shape[-1], inputs.samples.shape[-2])
        c = self.config
        floor = history_floor(inputs.hr_motion, c.history_gain_min, c.still_motion_px)
        steer = steer_from_lr(raw[:, :STEER_CHANNELS, :h, :w], trust_lr, c, hr_size, floor)
        if c.detail:  # luma only: (Y, 0, 0) in YCoCg adds Y to each of R, G and B
            luma = detail_luma(raw[:, STEER_CHANNELS:, :h, :w], inputs.samples.shape[-2:], c.detail_bound)
            steer.correction = torch.cat([luma, torch.zeros_like(luma), torch.zeros_like(luma)], dim=1)
        return blend(inputs, self.params, steer)


class NTAAULR(nn.Module):
    """``model(frame, state) -> (output, aux, state)``; see the module docstring.  Takes any scale:
    a frame may carry ``scale`` (N,), one value per batch (``takes_frame_scale``), which sets the HR
    size of a fresh history and the 1/s input of a ``scale_input`` net."""

    takes_frame_scale = True

    def __init__(self, config: NTAAULRConfig):
        super().__init__()
        self.config = config
        self.scale = config.scale
        self.params = TAAUParams(alpha=config.alpha)
        self.lr_gather = Gather(config, self.params)
        detail_in = config.npu_input_channels() - config.steer_input_channels()
        self.steer = SteerNet(config.steer_input_channels(), config.width, config.mid_layers, STEER_CHANNELS, detail_in,
                              config.detail_width, config.detail_reads == "all", config.detail_form)
        self.lr_accumulate = Accumulate(self.params, config)
        # (W, H) of the output at a fractional scale when it is not round_half_up(lr * s) (data made from a
        # display size: 1280x720 at 1.7 renders 753x424, and 424 * 1.7 rounds to 721); None: hr_dims
        self.output_size: tuple[int, int] | None = None

    def set_output_size(self, hr_size) -> None:
        """The HR size ``(W, H)`` of the frames about to run (the eval loop calls it); None: the scale's."""
        self.output_size = None if hr_size is None else (int(hr_size[0]), int(hr_size[1]))

    def hr_size(self, lr_hw, scale=None) -> tuple[int, int]:
        """``(W, H)`` of the output for LR frames of ``(h, w)`` at ``scale`` (default: the config's)."""
        scale = self.scale if scale is None else scale
        if self.output_size is not None and size_mismatch((lr_hw[1], lr_hw[0]), self.output_size, scale) is None:
            return self.output_size
        height, width = hr_dims(lr_hw, scale)
        return width, height

    # The detail branch as a fine-tune fits it (``finetune.detail``): display-only, so it can be fitted
    # on inputs and displays recorded once.  A model without the branch has none of these.
    @contextlib.contextmanager
    def recording_detail_inputs(self):
        """Within the block, each forward appends the branch's input (N, s*s, h', w') to the list yielded."""
        recorded, steer = [], self.steer
        hook = steer.register_forward_hook(lambda module, args, out: recorded.append(steer.detail_input(args[0])))
        try:
            yield recorded
        finally:
            hook.remove()

    def detail_input_channels(self) -> int:
        """The channels per LR pixel the branch reads (its recorded input)."""
        return branch_first_conv(self.steer.detail).in_channels

    def detail_parameters(self) -> dict[str, nn.Parameter]:
        """The branch's parameters by their names in the model."""
        return {f"steer.detail.{k}": p for k, p in self.steer.detail.named_parameters()}

    def detail_patch(self, branch_input: torch.Tensor, hr_hw: tuple[int, int]) -> torch.Tensor:
        """The luma patch (N, 1, H, W) the branch draws from ``branch_input`` (N, s*s, h, w)."""
        return detail_luma(self.steer.detail(branch_input), hr_hw, self.config.detail_bound)

    def stages(self) -> list[tuple[str, nn.Module, str]]:
        return [(n, getattr(self, n), getattr(self, n).placement) for n in STAGE_ORDER]

    def frame_scale(self, frame: dict):
        """The scale of this batch: the frame key ``scale`` (N,) when given (``takes_frame_scale``: one
        checkpoint trained or run at several scales, one scale per batch), else the config's."""
        value = frame.get("scale")
        if value is None:
            return self.scale
        value = float(value.reshape(-1)[0]) if torch.is_tensor(value) else float(value)
        value = round(value, 3)  # a float32 1.7 is 1.70000005: quality modes have at most 3 decimals
        return self.scale if value == float(self.scale) else parse_scale(value, "frame scale")

    def initial_state(self, frame: dict) -> dict:
        color = frame["color"]
        n, _, h, w = color.shape
        width, height = self.hr_size((h, w), self.frame_scale(frame))
        return {"history": color.new_zeros(n, 3, height, width), "weight": color.new_zeros(n, 1, height, width),
                "depth": sanitize_depth(frame["depth"]).clone()}

    def forward(self, frame: dict, state: dict | None = None):
        """One frame: color (N,3,h,w), depth (N,1,h,w), motion (N,2,h,w), jitter (N,2), optional
        reset (N,).  Returns output (N,3,H,W), aux {taau: the unsteered blend}, next state."""
        check_frame(frame, FRAME_SHAPES, self.scale, "ntaau_lr")
        color, motion = sanitize_colour(frame["color"]), sanitize_motion(frame["motion"])
        depth, jitter = sanitize_depth(frame["depth"]), frame["jitter"]
        # reset (N,), cut (N, 1, 1, 1): a cut history may hold anything, NaN included
        reset, cut, state = start_frame(frame, state, self.initial_state, color)
        previous_depth = torch.where(cut, depth, state["depth"])
        state = {"history": torch.where(cut, 0.0, state["history"]), "weight": torch.where(cut, 0.0, state["weight"])}
        hr_size = (state["history"].shape[-1], state["history"].shape[-2])
        inputs, trust_lr, features = self.lr_gather(color, depth, previous_depth, jitter, motion, reset, state, hr_size,
                                                    self.frame_scale(frame))
        output, next_state = self.lr_accumulate(inputs, trust_lr, self.steer(features))
        with torch.no_grad():
            taau, _ = blend(inputs, self.params)
        return output, {"taau": taau}, {**next_state, "depth": depth}
