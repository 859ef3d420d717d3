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

Scales: all three take an integer scale; at a fractional one (a quality mode such as 1.5x,
``ops.scale``) ``Bicubic`` and ``TAAU`` run (``FRACTIONAL_BASELINES``; TAAU maps each HR pixel to
LR by the exact per-axis ratio, ``model.taau``): FSR2 refuses it with one line, and the default
baselines at such a scale are the ones that take it.
"""

from __future__ import annotations

import dataclasses

import torch
import torch.nn.functional as F

from ..errors import UserError
from ..model.taau import TAAUInputs, TAAUParams, bicubic_resample, bicubic_upsample, blend, taau_inputs
from ..ops import scale as scales
from ..ops.fsr2 import FSR2Params, fsr2_frame


class Bicubic:
    """Bicubic upsampling (A = -0.75, clamp-to-edge), output clamped to [0, 1].

    Jitter-aware by default: each LR sample is placed where it was really
    shaded (pixel centre + jitter), which is worth about a decibel over
    pretending it sits at the pixel centre.  ``jitter_aware=False`` gives
    plain ``F.interpolate(mode="bicubic", align_corners=False)``.
    """

    def __init__(self, scale: int | float, jitter_aware: bool = True):
        # an integer scale stays the int it was (bit-identical results); a fractional one is checked
        self.scale = int(scale) if float(scale).is_integer() else scales.parse_scale(scale)
        self.jitter_aware = jitter_aware
        self.output_size: tuple[int, int] | None = None  # (W, H) of a fractional scale's output

    def set_output_size(self, hr_size) -> None:
        """The HR size ``(W, H)`` of the sequence about to run (the eval loop calls it): at a fractional
        scale the output size is the data's (``lr = round(hr / s)`` has several ``hr`` per ``lr``)."""
        self.output_size = (int(hr_size[0]), int(hr_size[1]))

    def upsample(self, color: torch.Tensor, jitter: torch.Tensor) -> torch.Tensor:
        """``(N, C, h, w)`` and jitter ``(N, 2)`` LR pixels -> ``(N, C, h*s, w*s)``, not clamped; at a
        fractional scale ``(N, C, H, W)`` of ``set_output_size`` (else ``round_half_up(h * s)``...)."""
        if isinstance(self.scale, float):
            h, w = color.shape[-2:]
            size = self.output_size or scales.hr_size_for((w, h), self.scale)
            return bicubic_resample(color, jitter if self.jitter_aware else torch.zeros_like(jitter), size)
        if not self.jitter_aware:
            return F.interpolate(color, scale_factor=self.scale, mode="bicubic", align_corners=False)
        return bicubic_upsample(color, jitter, self.scale)

    def __call__(self, frame: dict, state):
        return self.upsample(frame["color"], frame["jitter"]).clamp(0.0, 1.0), {}, state


def _integer_scale(method: str, scale) -> int:
    """``scale`` as an int, or the one-line refusal of a method that takes integer scales only."""
    if not float(scale).is_integer():
        raise UserError(f"the {method} baseline takes integer scales only so far, the data is x{float(scale):g} "
                        f"(at a fractional scale: --methods {' '.join(FRACTIONAL_BASELINES)})")
    return int(scale)


class TAAU:
    """Temporal anti-aliasing upsampler (:mod:`mnss_kit.model.taau`; keyword arguments are its
    :class:`~mnss_kit.model.taau.TAAUParams`)."""

    def __init__(self, scale: int | float, **params):
        # an integer scale stays the int it was (bit-identical results); a fractional one is checked
        self.scale = int(scale) if float(scale).is_integer() else scales.parse_scale(scale)
        self.params = TAAUParams(**params)
        self.output_size: tuple[int, int] | None = None  # (W, H) of a fractional scale's output

    def set_output_size(self, hr_size) -> None:
        """The HR size ``(W, H)`` of the sequence about to run (as ``Bicubic.set_output_size``)."""
        self.output_size = (int(hr_size[0]), int(hr_size[1]))

    def _hr_size(self, color: torch.Tensor, state):
        if state is not None or isinstance(self.scale, int) or self.output_size is None:
            return None  # the history's size, or the integer scale's
        h, w = color.shape[-2:]
        return self.output_size if scales.size_mismatch((w, h), self.output_size, self.scale) is None else None

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
            inputs = taau_inputs(color, frame["jitter"], frame["motion"], reset, state, self.scale, self.params,
                                 self._hr_size(color, state))
            output, new_state = blend(inputs, self.params)
        return output, inputs, new_state


class FSR2:
    """FSR2-class temporal upscaler (:mod:`mnss_kit.ops.fsr2`; keyword arguments are its
    :class:`~mnss_kit.ops.fsr2.FSR2Params`).  Each batch element runs through the numpy reference
    (one definition): tensors go to numpy and back, the state is a list of ``FSR2State``."""

    def __init__(self, scale: int, **params):
        self.scale = _integer_scale("fsr2", scale)
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
FRACTIONAL_BASELINES = ("bicubic", "taau")  # the baselines that take a fractional scale (1.5x, 1.7x) so far
DEFAULT_BASELINES = ("bicubic", "taau")


def baseline_settings() -> dict:
    """The default settings of the baselines with knobs (``fsr2``): a results file written under other
    settings is stale."""
    return {"fsr2": dataclasses.asdict(FSR2Params())}


def baseline_methods(scale: int | float, names=None) -> dict:
    """``{name: per-frame callable}`` for the named baselines at ``scale``; by default bicubic and
    taau, at a fractional scale those of them that take it (``FRACTIONAL_BASELINES``)."""
    return {name: BASELINES[name](scale) for name in (baselines_at(scale) if names is None else names)}


def baselines_at(scale: int | float, names=DEFAULT_BASELINES) -> list[str]:
    """Those of ``names`` that take ``scale``: all at an integer scale, ``FRACTIONAL_BASELINES`` at a fractional one."""
    return list(names) if float(scale).is_integer() else [n for n in names if n in FRACTIONAL_BASELINES]
