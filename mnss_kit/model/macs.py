"""Multiply-accumulates per HR output pixel: the hardware-independent cost of a model.

Learned convolutions are counted exactly by running one small frame with a hook
on every ``nn.Conv2d`` (``k*k*c_in/groups`` MACs per output element, zero
padding included, as usual).  The fixed-function GPU arithmetic is counted by
each family's rules (``Family.fixed_macs``), per element it produces, and reported apart
("fixed"), with these unit costs:

    bilinear sample        4 per channel (four weighted taps)
    blend w*a + (1-w)*b    2 per channel
    difference, |.|, +, x  1 per element each
    sigmoid / tanh         1 per element
    average pool           1 per input element
    unsharp kernel         5 per channel (its five non-zero taps)
    copies, gathers        0
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch
from torch import nn

from .mac_units import BILINEAR  # noqa: F401  (re-exported for the rules in the docstring)


@dataclass
class StageCost:
    placement: str
    conv: float = 0.0  # learned conv MACs per HR output pixel
    fixed: float = 0.0  # fixed-function MACs per HR output pixel (rules in the module docstring)

    @property
    def total(self) -> float:
        return self.conv + self.fixed


@dataclass
class MacReport:
    stages: dict[str, StageCost] = field(default_factory=dict)  # in execution order
    params: int = 0

    @property
    def total(self) -> float:
        return sum(c.total for c in self.stages.values())

    def by_placement(self, placement: str) -> float:
        return sum(c.total for c in self.stages.values() if c.placement == placement)

    def to_dict(self) -> dict:
        """Plain data for JSON reports and checkpoint records."""
        return {
            "macs_per_pixel": self.total,
            "npu_macs_per_pixel": self.by_placement("npu"),
            "gpu_macs_per_pixel": self.by_placement("gpu"),
            "params": self.params,
            "stages": {n: {"placement": c.placement, "conv": c.conv, "fixed": c.fixed} for n, c in self.stages.items()},
        }


def count_macs(model: nn.Module, lr_size: tuple[int, int] = (8, 8)) -> MacReport:
    """Run one frame of ``lr_size`` (h, w) through ``model`` and count its MACs per HR output pixel."""
    from .families import family_of
    from .family import example_frame
    from .taau import hr_dims

    h, w = lr_size
    family = family_of(model)
    # a still frame from torch's global generator, as earlier releases drew it: training runs that save
    # checkpoints (and so count MACs) between steps keep the random stream they had
    frame = example_frame(family, h, w, model.scale, still=True)
    frame = {k: v.to(next(model.parameters()).device) for k, v in frame.items()}
    hr_h, hr_w = hr_dims((h, w), model.scale)  # h * s, w * s at an integer scale
    hr_pixels = hr_h * hr_w
    stages = {name: StageCost(placement) for name, _, placement in model.stages()}
    hooks = []
    for name, module in model.named_modules():
        if isinstance(module, nn.Conv2d):
            stage = stages[name.split(".")[0]]
            hooks.append(module.register_forward_hook(_conv_counter(module, stage, hr_pixels)))
    try:
        with torch.no_grad():
            model(frame, model.initial_state(frame))
    finally:
        for hook in hooks:
            hook.remove()
    for name, cost in family.fixed_macs(model.config).items():
        if name in stages:
            stages[name].fixed = cost
    return MacReport(stages=stages, params=sum(p.numel() for p in model.parameters()))


def _conv_counter(conv: nn.Conv2d, stage: StageCost, hr_pixels: int):
    per_output = conv.in_channels // conv.groups * conv.kernel_size[0] * conv.kernel_size[1]

    def hook(module, inputs, output):
        stage.conv += output[0].numel() * per_output / hr_pixels

    return hook
