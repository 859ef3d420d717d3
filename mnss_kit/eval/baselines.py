"""Non-neural baselines with the model's per-frame interface.

``method(frame, state) -> (output, aux, state)`` on torch tensors
(``docs/architecture.md``); ``state`` is ``None`` on the first call.  The
evaluation loop runs these exactly like the model.

``Bicubic``  bicubic upsampling of the current LR frame only.
``TAAU``     temporal anti-aliasing upsampling in the style of Karis 2014
             (Unreal Engine 4), :mod:`mnss_kit.model.taau` with no steering:
             the same accumulation the ``ntaau`` family steers.
``FSR2``     an FSR2-class temporal upscaler (depth-clip disocclusion, thin-feature locks,
             Lanczos reconstruction, YCoCg variance clamp, optional RCAS):
             :mod:`mnss_kit.ops.fsr2`, run on the numpy reference itself.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from ..model.taau import TAAUInputs, TAAUParams, bicubic_upsample, blend, taau_inputs
from ..ops.fsr2 import FSR2Params, fsr2_frame


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
        had to work with (``scripts/studies/error_breakdown.py`` reads the history weight)."""
        color = frame["color"]
        reset = frame.get("reset")
        reset = color.new_zeros(color.shape[0]) if reset is None else reset.to(color)
        with torch.no_grad():
            inputs = taau_inputs(color, frame["jitter"], frame["motion"], reset, state, self.scale, self.params)
            output, new_state = blend(inputs, self.params)
        return output, inputs, new_state


class FSR2:
    """FSR2-class temporal upscaler (:mod:`mnss_kit.ops.fsr2`; keyword arguments are its
    :class:`~mnss_kit.ops.fsr2.FSR2Params`).  Each batch element runs through the numpy reference
    (one definition): tensors go to numpy and back, the state is a list of ``FSR2State``."""

    def __init__(self, scale: int, **params):
        self.scale = int(scale)
        self.params = FSR2Params(**params)

    def __call__(self, frame: dict, state):
        color = frame["color"]
        n = color.shape[0]
        reset = frame.get("reset")
        resets = [False] * n if reset is None else [bool(r) for r in reset.detach().cpu().numpy() > 0.5]
        reactive = frame.get("reactive")
        states = [None] * n if state is None else state
        outputs, next_states = [], []
        for i in range(n):
            output, next_state = fsr2_frame(
                _hwc(color[i]), _hwc(frame["depth"][i]), _hwc(frame["motion"][i]),
                frame["jitter"][i].detach().cpu().numpy(), states[i], self.scale, self.params, resets[i],
                None if reactive is None else _hwc(reactive[i]))
            outputs.append(torch.from_numpy(output).permute(2, 0, 1))
            next_states.append(next_state)
        return torch.stack(outputs).to(color), {}, next_states


def _hwc(x: torch.Tensor):
    """``(C, H, W)`` tensor -> ``(H, W, C)`` float32 numpy."""
    return x.detach().to(torch.float32).permute(1, 2, 0).cpu().numpy()


BASELINES = {"bicubic": Bicubic, "taau": TAAU, "fsr2": FSR2}


def baseline_methods(scale: int, names=("bicubic", "taau")) -> dict:
    """``{name: per-frame callable}`` for the named baselines at ``scale``."""
    return {name: BASELINES[name](scale) for name in names}
