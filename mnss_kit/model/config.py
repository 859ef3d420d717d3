"""The ``model:`` section of a model config file, and reading it.

A model config file (``configs/models/NAME.yaml``)::

    schema: 1
    model:  {family: mnss, scale: 2, ...}   # this module
    train:  {...}                           # read by the training stage, ignored here
    data:   {...}                           # read by the training stage, ignored here
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from ..config import CONFIG_DIR, apply_overrides, from_dict, read_yaml, resolve_config_path
from ..errors import UserError

SCHEMA_VERSION = 1
TOP_LEVEL_KEYS = ("schema", "model", "train", "data")


def aa_input_channels(history_at_samples: bool) -> int:
    """Input channels of the anti-aliasing net, in order (each RGB): avgpool(I_R), then I_R at this
    frame's sampled sub-pixels when ``history_at_samples``, then the LR colour.  The torch model,
    the GPU passes and the bundle follow this layout."""
    return 9 if history_at_samples else 6


@dataclass
class ModelConfig:
    """MNSS (Yang et al. 2023) with the knobs the config ladder and the ablations turn."""

    family: Literal["mnss"] = "mnss"
    scale: int = 2
    # what the next frame reuses: the model's output (paper), the previous LR frame upsampled, nothing
    history: Literal["output", "lr_frame", "none"] = "output"
    # lr: convolutions run on the pixel-unshuffled HR input (FuseSR trick); hr: every conv at HR (paper)
    recon_resolution: Literal["lr", "hr"] = "lr"
    recon_width: int = 32
    recon_layers: int = 4  # conv layers, >= 2
    aa_width: int = 16
    aa_layers: int = 3  # conv layers, >= 1
    # the AA net also sees I_R at the sub-pixels I_AA replaces (not in the paper; docs/architecture.md)
    aa_history_at_samples: bool = False
    inpaint_activation: Literal["sigmoid", "tanh"] = "sigmoid"  # tanh is clipped to [0, 1]
    # LR weights -> HR weight map: tile replication, or bilinear at the jittered sample positions
    weight_upsample: Literal["nearest", "bilinear"] = "bilinear"
    enhance: bool = False  # unsharp kernel on the displayed output (never on the history)
    enhance_beta: float = 0.15

    def __post_init__(self):
        if self.scale < 2:
            raise ValueError(f"scale must be >= 2, got {self.scale}")
        if self.recon_layers < 2 or self.aa_layers < 1:
            raise ValueError("recon_layers must be >= 2 and aa_layers >= 1")
        if min(self.recon_width, self.aa_width) < 1:
            raise ValueError("recon_width and aa_width must be >= 1")
        if not 0.0 <= self.enhance_beta <= 1.0:
            raise ValueError(f"enhance_beta must be in [0, 1], got {self.enhance_beta}")


# family -> config dataclass; the model classes are in ``families.MODELS``
CONFIGS = {"mnss": ModelConfig}


def model_config_from_dict(section: dict, source: str = "model config") -> ModelConfig:
    """Validate a ``model:`` section (plain data) into its family's dataclass."""
    if not isinstance(section, dict):
        raise UserError(f"{source}: 'model' must be a mapping")
    family = section.get("family", "mnss")
    if family not in CONFIGS:
        raise UserError(f"{source}: unknown model family '{family}' (one of: {', '.join(CONFIGS)})")
    return from_dict(CONFIGS[family], section, where="model", source=source)


def load_model_config(name_or_path: str | Path, overrides: list[str] | None = None) -> ModelConfig:
    """Read the ``model:`` section of a config file (a path or a name under ``configs/models``).

    ``overrides`` are ``--set`` items such as ``model.recon_width=64``.
    """
    path = resolve_config_path(str(name_or_path), "models")
    data = apply_overrides(read_yaml(path), overrides)
    unknown = sorted(set(data) - set(TOP_LEVEL_KEYS))
    if unknown:
        raise UserError(f"{path}: unknown top-level key '{unknown[0]}' (allowed: {', '.join(TOP_LEVEL_KEYS)})")
    schema = data.get("schema")
    if schema != SCHEMA_VERSION:
        raise UserError(f"{path}: 'schema' must be {SCHEMA_VERSION}, got {schema!r}")
    if "model" not in data:
        raise UserError(f"{path}: missing 'model' section")
    return model_config_from_dict(data["model"], source=str(path))


def config_names() -> list[str]:
    """Names of the shipped model configs (``configs/models/*.yaml``), sorted."""
    return sorted(p.stem for p in (CONFIG_DIR / "models").glob("*.yaml"))
