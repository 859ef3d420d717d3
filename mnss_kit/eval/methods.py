"""Per-frame methods built from a model: ``method(frame, state) -> (output, aux, state)``.

``model_method``       the model as it runs in a game (recurrent history).
``no_history_method``  the same weights with history ignored: every frame is
                       a reset, so the model sees only the current LR frame
                       (the single-frame ablation).
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

    return _with_output_size(run, model)


def _with_output_size(run, model):
    """``run`` with the model's ``set_output_size`` (a fractional-scale family's: the eval loop gives it
    the sequence's HR size, as the baselines get it), and for a model that reads the frame key
    ``scale`` (``takes_frame_scale``, docs/architecture.md) a ``set_scale`` whose value every frame
    then carries as ``scale`` (N,)."""
    if hasattr(model, "set_output_size"):
        run.set_output_size = model.set_output_size
    if getattr(model, "takes_frame_scale", False):
        inner, chosen = run, {}

        def run(frame: dict, state):
            if "scale" in chosen and "scale" not in frame:
                frame = dict(frame, scale=torch.full((frame["color"].shape[0],), chosen["scale"], dtype=torch.float32))
            return inner(frame, state)

        run.set_scale = lambda scale: chosen.update(scale=float(scale))
        if hasattr(inner, "set_output_size"):
            run.set_output_size = inner.set_output_size
    return run


def no_history_method(model: torch.nn.Module) -> Method:
    """The model with a reset forced on every frame (same weights, history never used)."""

    def run(frame: dict, state):
        frame = dict(frame, reset=torch.ones_like(frame["reset"]))
        output, aux, _ = model(frame, model.initial_state(frame))
        return output, aux, None

    return _with_output_size(run, model)


def default_methods(model: torch.nn.Module | None, scale: int) -> dict[str, Method]:
    """``{"model", "model_nohist", "bicubic", "taau"}`` (baselines only when ``model`` is None)."""
    methods: dict[str, Method] = {}
    if model is not None:
        model.eval()
        methods["model"] = model_method(model)
        methods["model_nohist"] = no_history_method(model)
    methods.update(baseline_methods(scale))
    return methods
