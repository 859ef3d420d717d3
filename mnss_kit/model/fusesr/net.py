"""Reduced FuseSR (Zhong et al., SIGGRAPH Asia 2023), mobile-sized, one frame at a time.

Per frame, with scale ``s``, LR size ``h x w`` and HR size ``H x W = sh x sw``:

    warp_history (gpu)  hybrid only: the previous output backward-warped by the upsampled motion
                       (``layers.warp_bilinear``, MNSS's warp of the colour)
    demodulate  (gpu)  L = (colour - emissive) / F_beta at LR in linear light, display-encoded;
                       0 where F_beta is about zero (``ops.demodulation``); off: the colour itself
    encode      (gpu)  LR encoder: one 3x3 conv + ReLU on L
    unshuffle   (gpu)  the NPU input at LR: [L, encoder features, warped history unshuffled,
                       HR G-buffers unshuffled] (``ops.demodulation.pixel_unshuffle`` order)
    backbone    (npu)  fusion convs at LR, head conv, pixel shuffle, one 3x3 conv at HR, plus a
                       learned 1x1 skip from the input: the HR residual over the nearest upsample
                       of L (a fresh net predicts 0)
    remodulate  (gpu)  L_HR = clamp(nearest upsample of L + residual, 0, 1) (``layers.add_upsampled``),
                       output = display(F_beta_HR * L_HR + emissive_HR); off: L_HR is the colour

State (hybrid): ``history`` (N,3,H,W), the previous output.  A reset frame sees a zero history.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ..layers import add_upsampled, demodulate, jittered_upsample, remodulate, upsample_motion, warp_bilinear
from ..taau import sanitize_colour, sanitize_depth, sanitize_gbuffer, sanitize_motion
from ..family import check_frame
from .config import GBUFFER_CHANNELS, FuseSRConfig

STAGE_ORDER = ("warp_history", "demodulate", "encode", "unshuffle", "backbone", "remodulate")
LR_KEYS = {"color": 3, "motion": 2}
DEMODULATION_KEYS = {"lr_fbeta": ("lr", 3), "lr_emissive": ("lr", 3), "hr_fbeta": ("hr", 3), "hr_emissive": ("hr", 3)}


def conv(c_in: int, c_out: int, separable: bool) -> nn.Module:
    """A 3x3 conv, or its depthwise-separable form (depthwise 3x3, then pointwise 1x1)."""
    if not separable:
        return nn.Conv2d(c_in, c_out, 3, padding=1)
    return nn.Sequential(nn.Conv2d(c_in, c_in, 3, padding=1, groups=c_in), nn.Conv2d(c_in, c_out, 1))


class Warp(nn.Module):
    """The previous output warped to this frame with the upsampled motion (clamp-to-edge)."""

    placement = "gpu"

    def __init__(self, scale: int):
        super().__init__()
        self.scale = scale

    def forward(self, history, motion):
        """history (N,3,H,W), motion (N,2,h,w) LR pixels -> (N,3,H,W)."""
        return warp_bilinear(history, upsample_motion(motion, self.scale))


class Demodulate(nn.Module):
    """Display-encoded L at LR (``layers.demodulate``)."""

    placement = "gpu"

    def forward(self, color, fbeta, emissive):
        return demodulate(color, fbeta, emissive)


class Encode(nn.Module):
    """The LR encoder: 3x3 conv + ReLU (``conv3x3_pass`` on the phone)."""

    placement = "gpu"

    def __init__(self, width: int):
        super().__init__()
        self.conv = nn.Conv2d(3, width, 3, padding=1)
        nn.init.kaiming_normal_(self.conv.weight, nonlinearity="relu")
        nn.init.zeros_(self.conv.bias)

    def forward(self, x):
        return torch.relu(self.conv(x))


class Unshuffle(nn.Module):
    """The NPU input: LR image and features, then the HR images pixel-unshuffled to LR."""

    placement = "gpu"

    def __init__(self, scale: int):
        super().__init__()
        self.scale = scale

    def forward(self, lr: list[torch.Tensor], hr: list[torch.Tensor]):
        """``lr`` (N,C,h,w) tensors, ``hr`` (N,C,H,W) tensors -> (N, sum C_lr + s^2 sum C_hr, h, w)."""
        return torch.cat([*lr, *(F.pixel_unshuffle(x, self.scale) for x in hr)], dim=1)


class Backbone(nn.Module):
    """The NPU part: Conv2d (bias, depthwise or not), ReLU, PixelShuffle, +; fx-traceable.

    ``forward(x)``: ``x`` (N, C, h, w) the packed LR input; returns the (N, 3, H, W) residual
    that :class:`Remodulate` adds to the nearest upsample of L.  No identity sits in the skip
    conv: its int8 per-channel weight scale would be 1/127 and every small learned weight beside
    it would round to that step (ops.demodulation).
    """

    placement = "npu"

    def __init__(self, c_in: int, scale: int, width: int, layers: int, hr_channels: int, separable: bool):
        super().__init__()
        mods: list[nn.Module] = []
        for i in range(layers):
            mods += [conv(c_in if i == 0 else width, width, separable), nn.ReLU()]
        mods += [conv(width, hr_channels * scale * scale, separable), nn.ReLU(), nn.PixelShuffle(scale)]  # ReLU commutes with the shuffle
        self.body = nn.Sequential(*mods)
        self.out = nn.Conv2d(hr_channels, 3, 3, padding=1)
        nn.init.zeros_(self.out.weight)  # a fresh net predicts no residual: the nearest upsample of L
        nn.init.zeros_(self.out.bias)
        self.skip = nn.Conv2d(c_in, 3 * scale * scale, 1)
        nn.init.zeros_(self.skip.weight)
        nn.init.zeros_(self.skip.bias)
        self.shuffle = nn.PixelShuffle(scale)

    def forward(self, x):
        return self.out(self.body(x)) + self.shuffle(self.skip(x))


class Remodulate(nn.Module):
    """The HR L (``layers.add_upsampled``), then display(F_beta_HR * L + emissive_HR) (``layers.remodulate``);
    without demodulation the HR L is the output."""

    placement = "gpu"

    def __init__(self, scale: int, demodulate: bool):
        super().__init__()
        self.scale, self.demodulate = scale, demodulate

    def forward(self, residual, l, fbeta=None, emissive=None):
        """Returns (output, the HR L)."""
        l_hr = add_upsampled(residual, l, self.scale)
        return (remodulate(l_hr, fbeta, emissive) if self.demodulate else l_hr), l_hr


class FuseSR(nn.Module):
    """``model(frame, state) -> (output, aux, state)``; see the module docstring and docs/architecture.md."""

    def __init__(self, config: FuseSRConfig):
        super().__init__()
        self.config = config
        self.scale = s = config.scale
        d = config.divisor
        encoder = config.encoder_width // d
        self.warp_history = Warp(s) if config.history else None
        self.demodulate = Demodulate() if config.demodulate else None
        self.encode = Encode(encoder)
        self.unshuffle = Unshuffle(s)
        c_in = config.npu_input_channels() + encoder
        self.backbone = Backbone(c_in, s, config.width // d, config.layers, config.hr_channels // d, config.variant == "l")
        self.remodulate = Remodulate(s, config.demodulate)

    def stages(self) -> list[tuple[str, nn.Module, str]]:
        """``[(name, module, placement)]`` of the stages that run, in execution order."""
        return [(n, getattr(self, n), getattr(self, n).placement) for n in STAGE_ORDER if getattr(self, n) is not None]

    def required_inputs(self) -> dict[str, int]:
        """Frame keys this model reads (besides ``jitter`` and ``reset``) and their channels."""
        keys = dict(LR_KEYS)
        if self.config.demodulate:
            keys.update({k: c for k, (_, c) in DEMODULATION_KEYS.items()})
        keys.update({f"hr_{g}": GBUFFER_CHANNELS[g] for g in self.config.ordered_gbuffers})
        return keys

    def initial_state(self, frame: dict) -> dict:
        """Empty history for ``frame``'s batch: ``history`` (N,3,H,W) (an empty dict without history)."""
        if not self.config.history:
            return {}
        n, _, h, w = frame["color"].shape
        return {"history": frame["color"].new_zeros(n, 3, h * self.scale, w * self.scale)}

    def forward(self, frame: dict, state: dict | None = None):
        """One frame (keys of :meth:`required_inputs`, ``jitter`` (N,2), optional ``reset`` (N,)).

        Returns output (N,3,H,W) display values, aux {upsampled (N,3,H,W) I_U (the validation
        floor), prediction (N,3,H,W) the HR L (the backbone's residual over the upsampled L), l (N,3,h,w)
        the LR L},
        and the next state.
        """
        check_frame(frame, self.required_inputs(), self.scale, "fusesr")
        # one bad frame costs one frame: NaN / Inf inputs never reach the history (ops.sanitize)
        color, jitter = sanitize_colour(frame["color"]), frame["jitter"]
        n = color.shape[0]
        if self.demodulate is not None:
            x = self.demodulate(color, sanitize_gbuffer(frame["lr_fbeta"]), sanitize_gbuffer(frame["lr_emissive"]))
        else:
            x = color
        hr = []
        if self.warp_history is not None:
            reset = frame.get("reset")
            reset = color.new_zeros(n) if reset is None else reset.to(color)
            if not state:
                state, reset = self.initial_state(frame), color.new_ones(n)
            cut = (reset > 0.5).view(n, 1, 1, 1)  # a cut history may hold anything, NaN included
            hr.append(self.warp_history(torch.where(cut, 0.0, state["history"]), sanitize_motion(frame["motion"])))
        hr += [sanitize_depth(frame["hr_depth"]) if g == "depth" else sanitize_gbuffer(frame[f"hr_{g}"])
               for g in self.config.ordered_gbuffers]
        packed = self.unshuffle([x, self.encode(x)], hr)
        residual = self.backbone(packed)
        fbeta, emissive = ((sanitize_gbuffer(frame["hr_fbeta"]), sanitize_gbuffer(frame["hr_emissive"]))
                           if self.config.demodulate else (None, None))
        output, prediction = self.remodulate(residual, x, fbeta, emissive)
        aux = {"upsampled": jittered_upsample(color, jitter, self.scale), "prediction": prediction, "l": x}
        return output, aux, ({"history": output} if self.config.history else {})
