"""The ntaau_lr family: a small encoder-decoder at LR steers the toolkit's TAAU accumulation
(``model.taau``) from depth and motion evidence, with a spatial fallback; its record, and where
each part lives.

    config.py    the ``model:`` section (:class:`~.config.NTAAULRConfig`)
    net.py       the torch model and its stages: lr_gather, steer, lr_accumulate
    costs.py     fixed-function MACs per stage
    gpu_plan.py  the bundle's GPU side: passes, resources, per-frame schedule

The loss is ``model.losses.DisplayLoss``.
"""

from __future__ import annotations

from ..family import Family
from .config import NTAAULRConfig
from .costs import fixed_macs


def _build(config: NTAAULRConfig):
    from .net import NTAAULR

    return NTAAULR(config)


def _loss(config: NTAAULRConfig, train):
    from ..losses import DisplayLoss

    return DisplayLoss(config.scale, train.perceptual_weight, train.flicker_weight, train.mse_weight)


def _gpu_plan(config: NTAAULRConfig, state_dict: dict, lr_size: tuple[int, int], npu: dict, profile: str,
              hr_size=None) -> dict:
    from .gpu_plan import bundle_gpu_plan

    return bundle_gpu_plan(config, state_dict, lr_size, npu, profile, hr_size)


NTAAU_LR_FAMILY = Family(
    name="ntaau_lr",
    config=NTAAULRConfig,
    build=_build,
    loss=_loss,
    lr_inputs=("color", "depth", "motion"),
    npu_stages=("steer",),
    gpu_plan=_gpu_plan,
    fixed_macs=fixed_macs,
    history_state="history",
    floor_output="taau",
    learned_prefixes=("steer",),
    npu_output_at_lr=True,
)
