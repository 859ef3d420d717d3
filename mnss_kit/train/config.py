"""Training configuration: the ``train:`` section and the experiment file that holds it.

An experiment file (``mnss_kit/configs/models/*.yaml``) has three sections::

    schema: 1
    model: {...}        # the family's config class (mnss_kit.model.families.FAMILIES)
    train: {...}        # TrainConfig below
    data:               # optional: render configs that create the data when it is missing
      train: train_x2    # a name under mnss_kit/configs/data/, or a path
      val: test_x2

Relative data directories are resolved against the working directory.
"""

from __future__ import annotations

from typing import Any

from dataclasses import dataclass, field
from pathlib import Path

from ..model.config import model_config_from_dict
from ..config import apply_overrides, from_dict, read_config_with_base, resolve_config_path, to_dict
from ..errors import UserError

SCHEMA_VERSION = 1


@dataclass
class TrainConfig:
    """Everything the training loop needs besides the model.

    Steps count optimizer updates; an epoch is ``steps_per_epoch`` of them
    (windows are drawn from an endless shuffled stream, so an epoch is a unit
    of schedule, not one pass over the data).
    """

    train_data: str | list[str] = "data/train_x2"  # sequence dir(s), or dir(s) of sequences
    val_data: str | list[str] | None = None  # held-out sequences for the PSNR curve
    window: int = 6  # T: frames per recurrent window that carry the loss
    burn_in: int = 0  # frames run before them without gradient or loss, to build up the history
    batch_size: int = 4  # windows per step and process
    crop: int = 32  # LR pixels (square); HR crop is crop * scale (several scales: rounded to each scale's grid)
    epochs: int = 10
    steps_per_epoch: int = 100
    total_steps: int | None = None  # overrides epochs * steps_per_epoch when set
    lr: float = 1e-3
    lr_schedule: str = "constant"  # "constant" or "cosine" (decays to lr_final over the run)
    lr_final: float = 1e-5
    betas: tuple[float, float] = (0.9, 0.999)
    eps: float = 1e-4
    perceptual_weight: float = 0.1  # w
    aa_weight: float = 5.0  # k
    flicker_weight: float = 0.0  # f: change of the error between consecutive frames (not in the paper; losses.py)
    mse_weight: float = 0.0  # m: mean squared error, the error PSNR measures (display-output families; losses.py)
    gt_history_epochs: int = 1  # E: epochs that feed the ground-truth previous frame as history
    crop_mask: bool = True  # leave out of the loss the pixels whose history came from outside the crop
    bptt: int = 0  # detach the history every K frames; 0 = backpropagate through the whole window
    seed: int = 0
    num_workers: int = 0  # DataLoader worker processes (0: load in the training process)
    cache_dir: str | None = None  # decoded-frame cache; default: .cache inside the (first) data directory
    threads: int = 0  # torch intra-op threads per process; 0 = its share of the idle cores (see distributed.cpu_threads)
    checkpoint_every: int = 50  # steps between last.pt writes
    log_every: int = 10  # steps between scalar summaries
    val_every: int = 100  # steps between validation passes (0: only at the end)
    val_windows: int = 4  # windows per validation pass
    val_crop: int | None = 64  # LR pixels; None = full frames
    log_dir: str | None = None  # TensorBoard directory; default OUT/logs
    time_budget_min: float | None = None  # stop cleanly (final checkpoint) after this much time
    augment: dict[str, float] = field(default_factory=dict)  # augmentation -> probability per training window (dataset/augment.py)
    # weights a new run starts from (a shipped name or a .pt path; ``--init`` wins): a fine-tune
    # config names the run it continues, so the whole recipe lives in configs
    init: str | None = None
    # parameter-name prefixes to train (e.g. ["steer.detail."]: only ntaau_lr's detail branch); the
    # rest stays frozen at its initial weights.  None: every parameter
    trainable: list[str] | None = None

    def __post_init__(self):
        positive = ("window", "batch_size", "crop", "epochs", "steps_per_epoch", "checkpoint_every", "log_every", "val_windows")
        for name in positive:
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        non_negative = ("burn_in", "gt_history_epochs", "bptt", "num_workers", "threads", "val_every",
                        "perceptual_weight", "aa_weight", "flicker_weight", "mse_weight")
        for name in non_negative:
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.total_steps is not None and self.total_steps < 1:
            raise ValueError(f"total_steps must be >= 1, got {self.total_steps}")
        if self.lr <= 0 or self.eps <= 0:
            raise ValueError("lr and eps must be positive")
        if self.lr_schedule not in ("constant", "cosine"):
            raise ValueError(f"lr_schedule must be 'constant' or 'cosine', got '{self.lr_schedule}'")
        if self.time_budget_min is not None and self.time_budget_min <= 0:
            raise ValueError(f"time_budget_min must be positive, got {self.time_budget_min}")
        from ..dataset.augment import check_augment

        check_augment(self.augment)

    @property
    def steps(self) -> int:
        """Optimizer steps of the whole run."""
        return self.total_steps if self.total_steps is not None else self.epochs * self.steps_per_epoch

    def epoch_of(self, step: int) -> int:
        """Epoch (0-based) that the update at ``step`` (0-based) belongs to."""
        return step // self.steps_per_epoch

    def uses_gt_history(self, step: int) -> bool:
        return self.epoch_of(step) < self.gt_history_epochs

    @property
    def frames_per_window(self) -> int:
        """Frames the loader reads per window: the burn-in, then the frames with loss."""
        return self.burn_in + self.window

    def train_dirs(self) -> list[Path]:
        return _as_paths(self.train_data)

    def val_dirs(self) -> list[Path]:
        return _as_paths(self.val_data) if self.val_data else []


def changed_train_keys(saved: dict, train: TrainConfig, ignore: frozenset | set = frozenset()) -> list[str]:
    """The ``train:`` keys whose value differs from a checkpoint record's ``saved`` train section; a
    key the record lacks (written before the key existed) counts as its default."""
    defaults, now = to_dict(TrainConfig()), to_dict(train)
    return sorted(k for k in now if k not in ignore and saved.get(k, defaults[k]) != now[k])


@dataclass
class DataSection:
    """Render configs that create the data directories when they do not exist yet."""

    # renders TrainConfig.train_data: one render config per directory, each a name or path with
    # optional overrides ("train_x2 jitter=center")
    train: str | list[str] | None = None
    val: str | list[str] | None = None  # renders TrainConfig.val_data
    test: str | None = None  # held-out test set for ``mnss-kit eval`` (not used by training)


@dataclass
class ExperimentConfig:
    model: Any  # the family's config dataclass (``load_experiment`` reads it with model.config.model_config_from_dict)
    train: TrainConfig = field(default_factory=TrainConfig)
    data: DataSection | None = None
    schema: int = SCHEMA_VERSION

    def __post_init__(self):
        if self.schema != SCHEMA_VERSION:
            raise ValueError(f"schema must be {SCHEMA_VERSION}, got {self.schema}")


def load_experiment(name_or_path: str | Path, overrides: list[str] | None = None) -> tuple[ExperimentConfig, Path]:
    """Read an experiment YAML (a path or a name under ``mnss_kit/configs/models/``) with ``--set`` overrides."""
    path = resolve_config_path(str(name_or_path), "models")
    data = apply_overrides(read_config_with_base(path, "models"), overrides)
    if "model" not in data:
        raise UserError(f"{path}: missing required key 'model'")
    experiment = from_dict(ExperimentConfig, data, source=str(path))
    experiment.model = model_config_from_dict(data["model"], source=str(path))
    return experiment, path


def _as_paths(value: str | list[str]) -> list[Path]:
    return [Path(v) for v in ([value] if isinstance(value, str) else value)]
