"""Per-frame methods built from a model: ``method(frame, state) -> (output, aux, state)``.

``model_method``       the model as it runs in a game (recurrent history).
``no_history_method``  the same weights with history ignored: every frame is
                       a reset, so the model sees only the current LR frame
                       (the single-frame ablation).
``bundle_method``      a deployment bundle through the emulator (the int8 model
                       as the phone runs it).
``default_methods``    model, model_nohist and the baselines, in that order.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import torch

from .baselines import baseline_methods

Method = Callable[[dict, Any], tuple]


def model_method(model: torch.nn.Module) -> Method:
    """The model with its recurrent state; ``state=None`` starts an empty history."""

    def run(frame: dict, state):
        if state is None:
            state = model.initial_state(frame)
        return model(frame, state)

    return run


def no_history_method(model: torch.nn.Module) -> Method:
    """The model with a reset forced on every frame (same weights, history never used)."""

    def run(frame: dict, state):
        frame = dict(frame, reset=torch.ones_like(frame["reset"]))
        output, aux, _ = model(frame, model.initial_state(frame))
        return output, aux, None

    return run


def default_methods(model: torch.nn.Module | None, scale: int) -> dict[str, Method]:
    """``{"model", "model_nohist", "bicubic", "taau"}`` (baselines only when ``model`` is None)."""
    methods: dict[str, Method] = {}
    if model is not None:
        model.eval()
        methods["model"] = model_method(model)
        methods["model_nohist"] = no_history_method(model)
    methods.update(baseline_methods(scale))
    return methods


def bundle_method(bundle, npu_profile: str = "tflite-ref") -> Method:
    """A deployment bundle through the desktop emulator (numpy GPU passes, ``npu_profile``'s NPU
    numerics): the int8 model as the phone runs it, scored like any other method.  The state is
    the emulator's own; ``None`` starts a sequence."""
    from ..emulate.frame_loop import Emulator

    emulator = Emulator(bundle, npu_profile)
    inputs = emulator.runner.inputs

    def run(frame: dict, state):
        if state is None:
            emulator.reset()
        arrays = {k: frame[k][0].permute(1, 2, 0).numpy() for k in inputs}
        result = emulator.run_frame({**arrays, "jitter": frame["jitter"][0].numpy(), "reset": bool(frame["reset"][0] > 0.5)})
        display = torch.from_numpy(result.display.astype(np.float32) / 255.0).permute(2, 0, 1)[None]
        return display, {}, emulator

    return run
