"""The ``model:`` section of an ntaau-family config."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

SCALES = (2, 3, 4)
STEER_CHANNELS = 6  # per HR pixel: history gain, sample gain, box widening, YCoCg correction (3)
FILTER_CHANNELS = 2  # per HR pixel, with a display filter: its axis and diagonal weights


@dataclass
class NTAAUConfig:
    """A network steering a TAAU accumulation (``model.taau``): per HR pixel it scales the history
    and sample weights, widens or narrows the clamp box and adds a correction of at most
    ``correction_bound`` per YCoCg channel.  Zero net outputs are the toolkit's TAAU."""

    family: Literal["ntaau"] = "ntaau"
    scale: int = 2
    width: int = 16  # steering net channels at LR
    layers: int = 3  # 3x3 convs, >= 2
    correction_bound: float = 0.1  # |correction| per YCoCg channel; 0: the net only steers the blend
    # 1: the net may trust the history more than TAAU does but never less; it rejects history only
    # by narrowing the clamp box, as TAAU does (0: the gain spans (0, 2))
    history_gain_min: float = 0.0
    # > 0: the floor holds only where the surface moved less than this many HR pixels since the
    # last frame, fading linearly to none at it (a moving history is soft, and the net may trust it
    # less than TAAU there); 0: everywhere
    still_motion_px: float = 0.0
    # > 0: the net also steers a 3x3 filter of the displayed frame (model.taau.display_filter), each
    # of its two weights (axis and diagonal neighbours) at most this; 0: no filter (6 channels)
    filter_bound: float = 0.0
    # > 0: the display filter's weights fade as exp(-filter_falloff (sx + sy)) with the history's
    # resample spread sx, sy (model.taau.filter_gain): where a fractional fetch has just blurred the
    # history the filter blurs less (TAAU fades the history's weight there with its blur_penalty, 1.5)
    filter_falloff: float = 0.0
    # the clamp box widens by at most this times its span on each side (it narrows by at most 0.5:
    # to its centre)
    box_bound: float = 0.5
    alpha: float = 0.1  # TAAU's converged blend factor (model.taau.TAAUParams)

    def __post_init__(self):
        if self.scale not in SCALES:
            raise ValueError(f"scale must be one of {list(SCALES)}, got {self.scale}")
        if self.layers < 2 or self.width < 2:
            raise ValueError("layers and width must be >= 2")
        if not 0.0 <= self.correction_bound <= 0.5:
            raise ValueError(f"correction_bound must be in [0, 0.5], got {self.correction_bound}")
        if not 0.0 <= self.history_gain_min <= 1.0:
            raise ValueError(f"history_gain_min must be in [0, 1], got {self.history_gain_min}")
        if self.still_motion_px < 0.0:
            raise ValueError(f"still_motion_px must be >= 0, got {self.still_motion_px}")
        if self.filter_falloff < 0.0:
            raise ValueError(f"filter_falloff must be >= 0, got {self.filter_falloff}")
        if not 0.0 < self.box_bound <= 4.0:
            raise ValueError(f"box_bound must be in (0, 4], got {self.box_bound}")
        if not 0.0 <= self.filter_bound <= 0.25:
            raise ValueError(f"filter_bound must be in [0, 0.25], got {self.filter_bound}")

    def steer_channels(self) -> int:
        """Raw steering values per HR pixel: 6, and 2 more with a display filter."""
        return STEER_CHANNELS + (FILTER_CHANNELS if self.filter_bound > 0 else 0)

    def npu_input_channels(self) -> int:
        """LR colour (3), clamped history (3 s^2), history weight (s^2) and clamp distance (s^2)."""
        return 3 + 5 * self.scale * self.scale
