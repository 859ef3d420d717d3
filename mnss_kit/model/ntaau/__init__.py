"""The ntaau family: a small network steers the toolkit's TAAU accumulation (``model.taau``);
its record, and where each part lives.

    config.py    the ``model:`` section (:class:`~.config.NTAAUConfig`)
    net.py       the torch model and its stages: taau_gather, steer, taau_accumulate
    costs.py     fixed-function MACs per stage
    gpu_plan.py  the bundle's GPU side: passes, resources, per-frame schedule

The loss is ``model.losses.DisplayLoss``.
"""

from __future__ import annotations

from ..family import Family
from .config import NTAAUConfig
from .costs import fixed_macs


def _build(config: NTAAUConfig):
    from .net import NTAAU

    return NTAAU(config)


def _loss(config: NTAAUConfig, train):
    from ..losses import DisplayLoss

    return DisplayLoss(config.scale, train.perceptual_weight, train.flicker_weight, train.mse_weight)


def _gpu_plan(config: NTAAUConfig, state_dict: dict, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    from .gpu_plan import bundle_gpu_plan

    return bundle_gpu_plan(config, state_dict, lr_size, npu, profile)


NTAAU_FAMILY = Family(
    name="ntaau",
    config=NTAAUConfig,
    build=_build,
    loss=_loss,
    lr_inputs=("color", "depth", "motion"),
    npu_stages=("steer",),
    gpu_plan=_gpu_plan,
    fixed_macs=fixed_macs,
    history_state="history",
    floor_output="taau",
    learned_prefixes=("steer",),
)
