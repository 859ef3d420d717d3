"""The model families by name, and building a model from its config.

``FAMILIES`` is the one table of families (see :mod:`.family`); each record lives in its
family's folder.  Light at import (no torch): the records load their torch code when called.
"""

from __future__ import annotations

from .family import Family
from .fusesr import FUSESR_FAMILY
from .mnss import MNSS_FAMILY
from .ntaau import NTAAU_FAMILY
from .ntaau_lr import NTAAU_LR_FAMILY

FAMILIES: dict[str, Family] = {"mnss": MNSS_FAMILY, "fusesr": FUSESR_FAMILY, "ntaau": NTAAU_FAMILY, "ntaau_lr": NTAAU_LR_FAMILY}


def family_named(name: str) -> Family:
    from ..errors import UserError

    if name not in FAMILIES:
        raise UserError(f"unknown model family '{name}' (one of: {', '.join(FAMILIES)})")
    return FAMILIES[name]


GENERIC_PLACEMENTS = ("default", "all-gpu", "auto")  # split.plan's own modes


def placement_modes() -> tuple[str, ...]:
    """``--placement`` choices: the generic modes and every family's named ones (``Family.placements``)."""
    named = dict.fromkeys(mode for family in FAMILIES.values() for mode in family.placements)
    return (*GENERIC_PLACEMENTS[:2], *named, GENERIC_PLACEMENTS[2])


def family_of(model_or_config) -> Family:
    """The record of a model's (or a model config's) family."""
    config = getattr(model_or_config, "config", model_or_config)
    return family_named(config.family)


def run_at_scale(model, scale, what: str = "--scale", where: str = "") -> None:
    """Make ``model`` run at ``scale`` (None: its own).  A model that reads the frame key ``scale``
    (``takes_frame_scale``: its net runs at LR) takes any; others only their own, refused in one line
    as eval refuses data at another scale (``family.check_data_scale``; ``where`` names the model there)."""
    from .family import check_data_scale

    if scale is None or float(scale) == float(model.scale):
        return
    if not getattr(model, "takes_frame_scale", False):
        check_data_scale(model.config.family, model.scale, scale, where=where, what=what)
    model.config.scale = scale  # the fixed-function costs and a fresh history's size follow the config
    model.scale = scale


def build_model(config):
    """A freshly initialised model of ``config.family`` (float32, CPU)."""
    return family_of(config).build(config)


def npu_modules(model) -> dict:
    """``{stage name: submodule}`` of the family's NPU stages, in execution order."""
    family = family_of(model)
    return {name: module for name, module, _ in model.stages() if name in family.npu_stages}


def npu_stage(model) -> tuple[str, object]:
    """``(name, submodule)`` of the one NPU stage of ``model`` (the int8 graph a bundle runs)."""
    from ..errors import UserError

    modules = npu_modules(model)
    if len(modules) != 1:
        raise UserError(f"a {model.config.family} model has NPU stages {list(modules)}; the toolkit quantizes exactly one")
    return next(iter(modules.items()))


def npu_module(model):
    """The one NPU stage's submodule (:func:`npu_stage`)."""
    return npu_stage(model)[1]


def npu_input_shapes(model, hr_size: tuple[int, int]) -> list[tuple[int, ...]]:
    """NCHW shapes of the NPU stage's inputs when ``model`` outputs ``hr_size`` = (W, H): one
    frame of the family's example inputs run through it, the stage's arguments recorded."""
    import torch

    from .family import example_frame

    w, h = hr_size
    scale = model.config.scale
    if float(scale).is_integer():
        lw, lh = w // scale, h // scale
    else:  # a quality mode: round_half_up(hr / s) per axis (ops.scale.lr_size_for)
        from ..ops.scale import lr_size_for

        lw, lh = lr_size_for((w, h), scale)
    frame = example_frame(family_of(model), lh, lw, scale, generator=torch.Generator().manual_seed(0))
    seen = []
    hook = npu_module(model).register_forward_pre_hook(lambda module, args: seen.append([tuple(a.shape) for a in args]))
    try:
        with torch.no_grad():
            model(frame)
    finally:
        hook.remove()
    return seen[0]


def npu_stage_name(model) -> str:
    """The one NPU stage's name (:func:`npu_stage`)."""
    return npu_stage(model)[0]


def randomise_convs(model, prefixes: tuple[str, ...] | None = None, noise: float = 0.05):
    """Random weights for an untrained example model (tests, benchmarks, doc examples); returns ``model``.

    The convs under ``prefixes`` (default: the family's ``learned_prefixes``) get weights and biases as PyTorch's Conv2d
    draws them by default (uniform within +-1/sqrt(fan_in)) plus N(0, ``noise``): every tensor
    carries signal (a fresh model's last convs are zero), quantization is not trivial, and a
    change to the model's own init does not move these numerics (a He-scaled random net amplifies
    int8 rounding several times more).
    """
    import math

    import torch
    from torch import nn

    prefixes = family_of(model).learned_prefixes if prefixes is None else prefixes
    with torch.no_grad():
        for name, module in model.named_modules():
            if name.startswith(prefixes) and isinstance(module, nn.Conv2d):
                bound = 1.0 / math.sqrt(module.weight[0].numel())
                for p in (module.weight, module.bias):
                    p.uniform_(-bound, bound).add_(torch.randn_like(p) * noise)
    return model
