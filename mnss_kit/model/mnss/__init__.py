"""The MNSS family (Yang et al., TVCG 2023): its record, and where each part lives.

    config.py    the ``model:`` section (:class:`~.config.MNSSConfig`)
    net.py       the torch model and its stages: warp, inpaint, aa, insert, recon, enhance
    loss.py      the training loss
    costs.py     fixed-function MACs per stage
    gpu_stage.py the GPU stage as numpy passes (golden frames, tests) and its learned weights
    gpu_plan.py  the bundle's GPU side: passes, resources, weight blocks, per-frame schedule
"""

from __future__ import annotations

from ..family import Family
from .config import MNSSConfig
from .costs import fixed_macs


def _build(config: MNSSConfig):
    from .net import MNSS

    return MNSS(config)


def _loss(config: MNSSConfig, train):
    from .loss import MNSSLoss

    if train.mse_weight:
        raise ValueError("train.mse_weight is a term of the display loss (ntaau, fusesr); the mnss loss has no such term")
    return MNSSLoss(config.scale, train.perceptual_weight, train.aa_weight, train.flicker_weight)


def _gpu_plan(config: MNSSConfig, state_dict: dict, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    from .gpu_plan import bundle_gpu_plan

    return bundle_gpu_plan(config, state_dict, lr_size, npu, profile)


MNSS_FAMILY = Family(
    name="mnss",
    config=MNSSConfig,
    build=_build,
    loss=_loss,
    lr_inputs=("color", "depth", "motion"),
    npu_stages=("recon",),
    gpu_plan=_gpu_plan,
    fixed_macs=fixed_macs,
    placements={"aa-on-npu": ("aa",)},
    history_state="history",
    floor_output="upsampled",
    learned_prefixes=("recon", "aa"),
)
