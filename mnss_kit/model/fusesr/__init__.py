"""The reduced FuseSR family (Zhong et al., SIGGRAPH Asia 2023): its record, and where each part lives.

    config.py    the ``model:`` section (:class:`~.config.FuseSRConfig`)
    net.py       the torch model and its stages: warp, demodulate, encode, unshuffle, backbone, remodulate
    costs.py     fixed-function MACs per stage
    gpu_plan.py  the bundle's GPU side: passes, resources, weight blocks, per-frame schedule
"""

from __future__ import annotations

from ..family import Family
from .config import FuseSRConfig
from .costs import fixed_macs


def _build(config: FuseSRConfig):
    from .net import FuseSR

    return FuseSR(config)


def _loss(config: FuseSRConfig, train):
    from ..losses import DisplayLoss

    return DisplayLoss(config.scale, train.perceptual_weight, train.flicker_weight, train.mse_weight)


def _gpu_plan(config: FuseSRConfig, state_dict: dict, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    from .gpu_plan import bundle_gpu_plan

    return bundle_gpu_plan(config, state_dict, lr_size, npu, profile)


FUSESR_FAMILY = Family(
    name="fusesr",
    config=FuseSRConfig,
    build=_build,
    loss=_loss,
    lr_inputs=("color", "depth", "motion", "fbeta", "emissive"),  # depth: warp_pass of the hybrid reads it
    hr_inputs=("fbeta", "emissive", "normal", "depth", "albedo"),
    npu_stages=("backbone",),
    gpu_plan=_gpu_plan,
    fixed_macs=fixed_macs,
    history_state="history",
    floor_output="upsampled",
    learned_prefixes=("encode", "backbone"),
)
