"""The ``model:`` section of an ntaau_lr-family config."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ...ops.taau_lr import STEER_CHANNELS  # noqa: F401  (the raw steering values per LR pixel; net and gpu_plan import it here)

SCALES = (2, 3, 4)  # the integer scales; any scale in [1.25, 4] is taken (``ops.scale.parse_scale``)
FEATURE_CHANNELS = 8  # per LR pixel: colour (3), history luma - colour luma, clamp distance, history weight,
#                       depth change since the last frame, motion spread
DETAIL_CHANNELS = 4  # per LR pixel with ``detail``: a luma patch over the pixel's HR footprint (net.detail_luma)


@dataclass
class NTAAULRConfig:
    """A network at LR steering a TAAU accumulation (``model.taau``) from evidence the GPU gathers
    cheaply (depth change, motion spread, clamp distance); its steering is upsampled on the GPU.
    Zero net outputs are the toolkit's TAAU."""

    family: Literal["ntaau_lr"] = "ntaau_lr"
    scale: int | float = 2  # 2, 3, 4 or a fractional quality mode such as 1.5 or 1.7 (an integral float becomes an int)
    width: int = 16  # channels at LR; the half-resolution level has twice as many
    mid_layers: int = 2  # 3x3 convs at half LR resolution (the encoder-decoder's inner level), >= 1
    box_bound: float = 2.0  # the clamp box widens by at most this times its span per side
    filter_bound: float = 0.25  # the display filter's two weights, each at most this
    # history trust above TAAU's (a history gain over 1, a wider clamp box) fades to none where the
    # depth grew by this share since the last frame (a disocclusion) ...
    trust_depth: float = 0.1
    # ... or where the motion differs from a neighbour's by this many LR pixels (an edge of a moving
    # object, where dilated or rigid motion vectors are wrong)
    trust_spread_px: float = 1.0
    alpha: float = 0.1  # TAAU's converged blend factor (model.taau.TAAUParams)
    # > 0: the history gain, after the trust gate, is at least this (ntaau's floor, model.taau.history_floor)
    history_gain_min: float = 0.0
    # > 0: the floor holds only where the surface moved less than this many HR pixels since the last
    # frame, fading linearly to none at it; 0: everywhere
    still_motion_px: float = 0.0
    # the NPU input gets a 9th channel, 1 / scale (a constant map), so one checkpoint can serve several scales
    scale_input: bool = False
    # a detail branch beside the steering: a net of detail_width at LR (detail_form) reads the clamped
    # history's luma at each of the s x s HR pixels of an LR pixel (and with detail_reads "all" the
    # steering's features too) and writes a luma patch per LR pixel (4 more
    # outputs, each at most detail_bound) added to the display.  Its last conv starts at zero, so a
    # model given the branch starts as the one without it; it is display-only (the history never
    # holds it).  Integer scales only.  In a bundle the NPU input gets the s x s luma channels and the
    # output the 4 patch values, which share the steering's int8 scale (one concatenation)
    detail: bool = False
    detail_bound: float = 0.1
    detail_width: int = 16
    # what the branch's first conv reads: "history" the s x s history luma only; "all" the steering's
    # features too (this frame's colour, depth change, clamp distance ...).  The NPU input is the same
    # either way: the exported branch reads every input channel (FullInputSteerNet)
    detail_reads: Literal["history", "all"] = "history"
    # the branch's net: "convs" three convs 3x3 at LR; "unet" an encoder-decoder as the steering's
    # (conv, two convs at half LR, conv 1x1, conv), about twice the receptive field
    detail_form: Literal["convs", "unet"] = "convs"

    def __post_init__(self):
        from ...errors import UserError
        from ...ops.scale import MAX_SCALE, MIN_SCALE, parse_scale

        if isinstance(self.scale, bool) or not isinstance(self.scale, (int, float)):
            raise ValueError(f"scale must be a number in [{MIN_SCALE}, {MAX_SCALE}], got {self.scale!r}")
        try:
            self.scale = parse_scale(self.scale)  # an integral value stays (or becomes) an int: 2, not 2.0
        except UserError as e:
            raise ValueError(str(e)) from None
        if self.width < 2 or self.mid_layers < 1:
            raise ValueError("width must be >= 2 and mid_layers >= 1")
        if not 0.0 < self.box_bound <= 4.0:
            raise ValueError(f"box_bound must be in (0, 4], got {self.box_bound}")
        if not 0.0 <= self.filter_bound <= 0.25:
            raise ValueError(f"filter_bound must be in [0, 0.25], got {self.filter_bound}")
        if self.trust_depth <= 0.0 or self.trust_spread_px <= 0.0:
            raise ValueError("trust_depth and trust_spread_px must be > 0")
        if not 0.0 <= self.history_gain_min <= 1.0:
            raise ValueError(f"history_gain_min must be in [0, 1], got {self.history_gain_min}")
        if self.detail and not float(self.scale).is_integer():
            raise ValueError(f"detail takes integer scales only, got {self.scale}")
        if self.detail_form not in ("convs", "unet"):
            raise ValueError(f"detail_form must be convs or unet, got {self.detail_form!r}")
        if self.detail_reads not in ("history", "all"):
            raise ValueError(f"detail_reads must be history or all, got {self.detail_reads!r}")
        if not 0.0 < self.detail_bound <= 0.5:
            raise ValueError(f"detail_bound must be in (0, 0.5], got {self.detail_bound}")
        if self.still_motion_px < 0.0:
            raise ValueError(f"still_motion_px must be >= 0, got {self.still_motion_px}")

    def steer_input_channels(self) -> int:
        return FEATURE_CHANNELS + (1 if self.scale_input else 0)

    def npu_input_channels(self) -> int:
        return self.steer_input_channels() + (int(self.scale) ** 2 if self.detail else 0)

    def steer_channels(self) -> int:
        return STEER_CHANNELS + (DETAIL_CHANNELS if self.detail else 0)
