"""MNSS (Yang et al., TVCG 2023): mobile neural supersampling, one frame at a time.

Per frame, with scale ``s``, LR size ``h x w`` and HR size ``H x W = sh x sw``:

    warp     (gpu)  previous output I_SS and upsampled previous depth, backward-warped by the
                    upsampled current motion (D_W = -1 where that leaves the frame) -> I_W, D_W
    inpaint  (gpu)  |LR colour, depth - I_W, D_W at this frame's sub-pixels| -> 3x3 conv ->
                    sigmoid (or tanh clipped to [0, 1]) -> upsampled (bilinear at the jittered
                    sample positions, or nearest) to the HR weight map M_w; I_U = LR samples at
                    their sampled HR pixels, the rest bilinear (``ops.subpixel.jittered_upsample``);
                    rectified history I_R = M_w I_U + (1 - M_w) I_W
    aa       (gpu)  conv net on [avgpool(I_R), LR colour] -> I_AA (LR); with
                    ``aa_history_at_samples`` also I_R at this frame's sub-pixels
    insert   (gpu)  I_AA written into I_R at this frame's sub-pixels
    recon    (npu)  conv net, residual on its input, clamped to [0, 1]   -> I_SS
    enhance  (gpu)  optional unsharp kernel on the displayed output

State: ``history`` (N,3,H,W), and the previous frame's LR ``depth`` (N,1,h,w) and ``jitter``
(N,2); the previous depth is upsampled like I_U, with its own jitter.  A reset frame (camera cut,
first frame) forces M_w = 1, so the history is ignored.

A sample whose engine colour is not finite (NaN or Inf in any channel, ``ops.sanitize``) is no
sample: its LR inpainting weight is 0 (the warped history is kept there) and I_AA is not inserted
at its sub-pixel (the rectified history stays), so one bad frame never puts the sanitized value
into the history.  On finite inputs nothing changes.
"""

from __future__ import annotations

import torch
from torch import nn

from .config import MNSSConfig, aa_input_channels
from ..blocks import conv_stack
from ..family import check_frame
from ..layers import (
    avgpool,
    extract_samples,
    insert_samples,
    jittered_upsample,
    offscreen,
    unsharp,
    upsample_bilinear,
    upsample_motion,
    warp_bilinear,
)
from ..taau import colour_not_finite, sanitize_colour, sanitize_depth, sanitize_motion
from ...ops.warp import OFFSCREEN_DEPTH

STAGE_ORDER = ("warp", "inpaint", "aa", "insert", "recon", "enhance")
FRAME_SHAPES = {"color": 3, "depth": 1, "motion": 2}  # LR buffers and their channel counts


class Warp(nn.Module):
    """Backward bilinear warp of the history and of the previous depth (clamp-to-edge).

    Where the surface was outside the previous frame the warped depth is ``OFFSCREEN_DEPTH``,
    so the inpainting sees a depth difference of at least 1 there and can drop the clamped
    edge texels a fast pan would otherwise carry in as history.
    """

    placement = "gpu"

    def __init__(self, scale: int):
        super().__init__()
        self.scale = scale

    def forward(self, history, prev_depth, prev_jitter, motion):
        """history (N,3,H,W), prev_depth (N,1,h,w), prev_jitter (N,2), motion (N,2,h,w) LR px
        -> (I_W (N,3,H,W), D_W (N,1,H,W))."""
        hr_motion = upsample_motion(motion, self.scale)
        hr_depth = jittered_upsample(prev_depth, prev_jitter, self.scale)
        warped = warp_bilinear(torch.cat([history, hr_depth], dim=1), hr_motion)
        warped_depth = torch.where(offscreen(hr_motion), OFFSCREEN_DEPTH, warped[:, 3:])
        return warped[:, :3], warped_depth


class Inpaint(nn.Module):
    """Weight map M_w from the disagreement of the current samples with the warped history."""

    placement = "gpu"

    def __init__(self, scale: int, activation: str = "sigmoid", weight_upsample: str = "bilinear", learned: bool = True):
        super().__init__()
        self.scale = scale
        self.activation = activation
        self.weight_upsample = weight_upsample
        self.conv = nn.Conv2d(4, 1, 3, padding=1) if learned else None
        if learned:  # start trusting a matching history and replacing a clearly different one
            nn.init.constant_(self.conv.weight, 10.0 / 36.0)
            nn.init.constant_(self.conv.bias, -2.0)

    def lr_weights(self, color, depth, jitter, warped, warped_depth):
        """(N,1,h,w) in [0, 1]: 1 = take the current frame, 0 = keep the history."""
        past_color = extract_samples(warped, jitter, self.scale)
        past_depth = extract_samples(warped_depth, jitter, self.scale)
        x = self.conv(torch.cat([(color - past_color).abs(), (depth - past_depth).abs()], dim=1))
        return torch.sigmoid(x) if self.activation == "sigmoid" else torch.clamp(torch.tanh(x), 0.0, 1.0)

    def forward(self, color, depth, jitter, warped, warped_depth, reset, invalid=None):
        """LR colour (N,3,h,w), depth (N,1,h,w), jitter (N,2), I_W, D_W (or None: no history),
        reset (N,1,1,1) bool, ``invalid`` (N,1,h,w) bool or None: samples that are no samples
        (weight 0) -> (I_R (N,3,H,W), M_w (N,1,H,W), I_U (N,3,H,W))."""
        upsampled = jittered_upsample(color, jitter, self.scale)
        if warped is None:
            return upsampled, torch.ones_like(upsampled[:, :1]), upsampled
        lr = self.lr_weights(color, depth, jitter, warped, warped_depth)
        if invalid is not None:
            lr = torch.where(invalid, 0.0, lr)
        if self.weight_upsample == "nearest":
            weight = torch.repeat_interleave(torch.repeat_interleave(lr, self.scale, dim=2), self.scale, dim=3)
        else:  # the LR weights belong to the jittered sample positions
            weight = upsample_bilinear(lr, self.scale, offset=jitter)
        weight = torch.where(reset, torch.ones_like(weight), weight)
        rectified = weight * upsampled + (1.0 - weight) * warped
        return rectified, weight, upsampled


class AntiAlias(nn.Module):
    """I_AA: the LR frame cleaned with the help of the rectified history (residual on the LR frame).

    The paper's input is the pooled history and the LR frame.  ``history_at_samples`` adds the
    rectified history at the sub-pixels this frame samples, which I_AA replaces: without it a
    static view flickers, because each frame swaps accumulated values for fresh aliased samples
    the net cannot compare them with.
    """

    placement = "gpu"

    def __init__(self, scale: int, width: int, layers: int, history_at_samples: bool = False):
        super().__init__()
        self.scale = scale
        self.history_at_samples = history_at_samples
        self.net = conv_stack(aa_input_channels(history_at_samples), width, layers, 3)

    def forward(self, rectified, color, jitter):
        """I_R (N,3,H,W), LR colour (N,3,h,w), jitter (N,2) -> I_AA (N,3,h,w) in [0, 1]."""
        inputs = [avgpool(rectified, self.scale)]
        if self.history_at_samples:
            inputs.append(extract_samples(rectified, jitter, self.scale))
        x = torch.cat([*inputs, color], dim=1)
        return torch.clamp(color + self.net(x), 0.0, 1.0)


class Insert(nn.Module):
    """I_AA written into the rectified history at this frame's sampled sub-pixels."""

    placement = "gpu"

    def __init__(self, scale: int):
        super().__init__()
        self.scale = scale

    def forward(self, rectified, aa, jitter, invalid=None):
        """I_R (N,3,H,W), I_AA (N,3,h,w), jitter (N,2), ``invalid`` (N,1,h,w) bool or None: samples
        not inserted -> (N,3,H,W)."""
        if invalid is not None:
            aa = torch.where(invalid, extract_samples(rectified, jitter, self.scale), aa)
        return insert_samples(rectified, aa, jitter, self.scale)


class Reconstruction(nn.Module):
    """The NPU part: Conv2d (bias), ReLU, PixelUnshuffle/PixelShuffle, +, clamp; fx-traceable.

    ``forward(image)``: ``image`` is (N, 3, H, W) float32 NCHW in [0, 1], the rectified history
    with I_AA inserted; returns I_SS (N, 3, H, W) in [0, 1] = clamp(image + residual).
    ``resolution="lr"`` pixel-unshuffles the input so every conv runs at LR on 3*s*s channels and
    pixel-shuffles the residual back; ``"hr"`` runs every conv at HR on 3 channels.
    """

    placement = "npu"

    def __init__(self, scale: int, width: int, layers: int, resolution: str = "lr"):
        super().__init__()
        self.scale = scale
        self.resolution = resolution
        channels = 3 * scale * scale if resolution == "lr" else 3
        if resolution == "lr":
            self.unshuffle = nn.PixelUnshuffle(scale)
            self.shuffle = nn.PixelShuffle(scale)
        self.body = conv_stack(channels, width, layers, channels)

    def forward(self, image):
        if self.resolution == "lr":
            residual = self.shuffle(self.body(self.unshuffle(image)))
        else:
            residual = self.body(image)
        return torch.clamp(image + residual, 0.0, 1.0)


class Enhance(nn.Module):
    """Unsharp kernel of ``ops.sharpen`` on the displayed output."""

    placement = "gpu"

    def __init__(self, beta: float):
        super().__init__()
        self.beta = beta

    def forward(self, image):
        """(N,3,H,W) -> (N,3,H,W) in [0, 1]."""
        return unsharp(image, self.beta)


class MNSS(nn.Module):
    """``model(frame, state) -> (output, aux, state)``; see the module docstring and docs/architecture.md."""

    def __init__(self, config: MNSSConfig):
        super().__init__()
        self.config = config
        self.scale = s = config.scale
        with_history = config.history != "none"
        self.warp = Warp(s) if with_history else None
        self.inpaint = Inpaint(s, config.inpaint_activation, config.weight_upsample, learned=with_history)
        self.aa = AntiAlias(s, config.aa_width, config.aa_layers, config.aa_history_at_samples)
        self.insert = Insert(s)
        self.recon = Reconstruction(s, config.recon_width, config.recon_layers, config.recon_resolution)
        self.enhance = Enhance(config.enhance_beta) if config.enhance else None

    def stages(self) -> list[tuple[str, nn.Module, str]]:
        """``[(name, module, placement)]`` of the stages that run, in execution order."""
        return [(n, getattr(self, n), getattr(self, n).placement) for n in STAGE_ORDER if getattr(self, n) is not None]

    def initial_state(self, frame: dict) -> dict:
        """Empty history for ``frame``'s batch: ``history`` (N,3,H,W), ``depth`` (N,1,h,w), ``jitter`` (N,2)."""
        color = frame["color"]
        n, _, h, w = color.shape
        return {
            "history": color.new_zeros(n, 3, h * self.scale, w * self.scale),
            "depth": color.new_zeros(n, 1, h, w),
            "jitter": color.new_zeros(n, 2),
        }

    def forward(self, frame: dict, state: dict | None = None):
        """One frame.  ``frame``: color (N,3,h,w), depth (N,1,h,w), motion (N,2,h,w), jitter (N,2),
        optional reset (N,).  ``state`` None means an empty history and a reset.

        Returns output (N,3,H,W), aux {aa (N,3,h,w), weight_map (N,1,H,W), history (N,3,H,W)
        rectified, upsampled (N,3,H,W) I_U, recon (N,3,H,W) before enhancement}, and the next
        state (still attached to the graph; detach it for truncated backpropagation).
        """
        check_frame(frame, FRAME_SHAPES, self.scale, "mnss")
        # one bad frame costs one frame: NaN / Inf inputs never reach the history (ops.sanitize)
        color, depth, motion = sanitize_colour(frame["color"]), sanitize_depth(frame["depth"]), sanitize_motion(frame["motion"])
        invalid = colour_not_finite(frame["color"])  # no sample: keep the history there
        jitter = frame["jitter"]
        n = color.shape[0]
        reset = frame.get("reset")
        reset = color.new_zeros(n) if reset is None else reset.to(color)
        if state is None:
            state, reset = self.initial_state(frame), color.new_ones(n)
        cut = (reset > 0.5).view(n, 1, 1, 1)
        warped = warped_depth = None
        if self.warp is not None:  # a cut history may hold anything, NaN included: zero it first
            history = torch.where(cut, 0.0, state["history"])
            prev_depth = torch.where(cut, 0.0, state["depth"])
            prev_jitter = torch.where(cut.view(n, 1), 0.0, state["jitter"])
            warped, warped_depth = self.warp(history, prev_depth, prev_jitter, motion)
        rectified, weight_map, upsampled = self.inpaint(color, depth, jitter, warped, warped_depth, cut, invalid)
        aa = self.aa(rectified, color, jitter)
        recon = self.recon(self.insert(rectified, aa, jitter, invalid))
        output = self.enhance(recon) if self.enhance is not None else recon
        aux = {"aa": aa, "weight_map": weight_map, "history": rectified, "upsampled": upsampled, "recon": recon}
        next_history = recon if self.config.history == "output" else upsampled
        return output, aux, {"history": next_history, "depth": depth, "jitter": jitter}
