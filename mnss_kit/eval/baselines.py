"""Non-neural baselines with the model's per-frame interface.

``method(frame, state) -> (output, aux, state)`` on torch tensors
(``docs/architecture.md``); ``state`` is ``None`` on the first call.  The
evaluation loop runs these exactly like the model.

``Bicubic``  bicubic upsampling of the current LR frame only.
``TAAU``     temporal anti-aliasing upsampling in the style of Karis 2014
             (Unreal Engine 4), :mod:`mnss_kit.model.taau` with no steering:
             the same accumulation the ``ntaau`` family steers.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from ..model.taau import TAAUInputs, TAAUParams, bicubic_upsample, blend, taau_inputs


class Bicubic:
    """Bicubic upsampling (A = -0.75, clamp-to-edge), output clamped to [0, 1].

    Jitter-aware by default: each LR sample is placed where it was really
    shaded (pixel centre + jitter), which is worth about a decibel over
    pretending it sits at the pixel centre.  ``jitter_aware=False`` gives
    plain ``F.interpolate(mode="bicubic", align_corners=False)``.
    """

    def __init__(self, scale: int, jitter_aware: bool = True):
        self.scale = int(scale)
        self.jitter_aware = jitter_aware

    def upsample(self, color: torch.Tensor, jitter: torch.Tensor) -> torch.Tensor:
        """``(N, C, h, w)`` and jitter ``(N, 2)`` LR pixels -> ``(N, C, h*s, w*s)``, not clamped."""
        if not self.jitter_aware:
            return F.interpolate(color, scale_factor=self.scale, mode="bicubic", align_corners=False)
        return bicubic_upsample(color, jitter, self.scale)

    def __call__(self, frame: dict, state):
        return self.upsample(frame["color"], frame["jitter"]).clamp(0.0, 1.0), {}, state


class TAAU:
    """Temporal anti-aliasing upsampler (:mod:`mnss_kit.model.taau`; keyword arguments are its
    :class:`~mnss_kit.model.taau.TAAUParams`)."""

    def __init__(self, scale: int, **params):
        self.scale = int(scale)
        self.params = TAAUParams(**params)

    def __call__(self, frame: dict, state):
        output, _, new_state = self.step(frame, state)
        return output, {}, new_state

    def step(self, frame: dict, state) -> tuple[torch.Tensor, TAAUInputs, dict]:
        """One frame -> ``(output, the blend's inputs, next state)``: the inputs say what the blend
        had to work with (``scripts/error_breakdown.py`` reads the history weight)."""
        color = frame["color"]
        reset = frame.get("reset")
        reset = color.new_zeros(color.shape[0]) if reset is None else reset.to(color)
        with torch.no_grad():
            inputs = taau_inputs(color, frame["jitter"], frame["motion"], reset, state, self.scale, self.params)
            output, new_state = blend(inputs, self.params)
        return output, inputs, new_state


BASELINES = {"bicubic": Bicubic, "taau": TAAU}


def baseline_methods(scale: int, names=("bicubic", "taau")) -> dict:
    """``{name: per-frame callable}`` for the named baselines at ``scale``."""
    return {name: BASELINES[name](scale) for name in names}
