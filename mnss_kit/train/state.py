"""Training checkpoints: ``last.pt`` to resume a run, ``model.pt`` to ship it.

``last.pt`` is a model checkpoint (``mnss_kit.model.checkpoint.load`` reads it)
with one more entry, ``train_state``: optimizer state, step, epoch, elapsed
training time, the loss of the last logged steps and every RNG state.  All of
it is tensors and plain data, so it loads with ``weights_only=True``.
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import torch
from torch import nn

from ..errors import UserError
from ..fileio import atomic_output_path
from ..model import checkpoint
from ..model.config import describes

LAST = "last.pt"
FINAL = "model.pt"


def rng_state() -> dict:
    """Every RNG the training process could draw from, as tensors and plain data."""
    kind, keys, pos, has_gauss, cached = np.random.get_state()
    return {
        "torch": torch.get_rng_state(),
        "numpy": {"kind": kind, "keys": torch.from_numpy(keys.astype(np.int64)), "pos": int(pos), "has_gauss": int(has_gauss), "cached": float(cached)},
        "python": random.getstate(),
    }


def set_rng_state(state: dict) -> None:
    torch.set_rng_state(state["torch"])
    n = state["numpy"]
    np.random.set_state((n["kind"], n["keys"].numpy().astype(np.uint32), n["pos"], n["has_gauss"], n["cached"]))
    version, internal, gauss = state["python"]
    random.setstate((version, tuple(internal), gauss))


def save_last(path: Path, model: nn.Module, record: dict, optimizer: torch.optim.Optimizer, progress: dict) -> Path:
    """Write ``last.pt`` atomically: ``checkpoint``'s record and weights plus ``train_state``.

    ``progress`` holds ``step`` (updates done), ``epoch``, ``elapsed_s`` and ``recent_loss``.
    """
    payload = {
        "record": checkpoint.make_record(model, record),
        "state_dict": {k: v.detach().cpu() for k, v in model.state_dict().items()},
        "train_state": {**progress, "optimizer": optimizer.state_dict(), "rng": rng_state()},
    }
    with atomic_output_path(path) as tmp:
        torch.save(payload, tmp)
    return path


def load_last(path: Path, model: nn.Module, optimizer: torch.optim.Optimizer) -> tuple[dict, dict]:
    """Restore weights, optimizer and RNGs from ``last.pt``; returns ``(record, train_state)``."""
    record, state_dict = checkpoint.read_record(path)
    if not describes(record.get("config"), model.config):
        raise UserError(f"the model config differs from the one {path} was trained with; resume with the same model: section")
    payload = torch.load(path, map_location="cpu", weights_only=True)
    train_state = payload.get("train_state")
    if not isinstance(train_state, dict):
        raise UserError(f"{path} holds no training state (a final model.pt cannot be resumed; use last.pt)")
    try:
        model.load_state_dict(state_dict)
        optimizer.load_state_dict(train_state["optimizer"])
    except (RuntimeError, ValueError, KeyError) as e:
        raise UserError(f"{path} does not fit this model config ({str(e).strip().splitlines()[0]})") from None
    set_rng_state(train_state["rng"])
    return record, train_state


def save_final(path: Path, model: nn.Module, record: dict) -> Path:
    """``model.pt``: weights and the self-describing record, through ``checkpoint.save``."""
    return checkpoint.save(path, model, record)
