"""Self-describing checkpoints: weights plus a plain-data record of what they are.

A checkpoint is ``torch.save({"record": record, "state_dict": weights})``; the
record holds only plain data (dict, list, str, int, float, bool, None), so
``torch.load(weights_only=True)`` reads it without unpickling code.

Record keys written by ``save``: ``format``, ``version``, ``family``, ``config``
(the ``model:`` section), ``scale``, ``jitter_pattern``, ``data_fingerprint``,
``code_version``, ``training`` (summary from the trainer), ``macs`` (the
``MacReport`` as data), ``macs_per_pixel``, ``params``.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import torch
from torch import nn

from .. import __version__
from ..config import to_dict
from ..errors import UserError
from ..fileio import atomic_output_path, sha256_file
from ..ops.jitter import pattern_name
from ..resources import ZOO_DIR
from .config import model_config_from_dict
from .families import build_model
from .macs import count_macs

FORMAT_TAG = "mnss-kit-checkpoint"
FORMAT_VERSION = 1
CALLER_KEYS = ("jitter_pattern", "data_fingerprint", "training")  # what the trainer supplies
PLAIN_TYPES = (dict, list, tuple, str, int, float, bool, type(None))


def code_version() -> str:
    """``mnss_kit.__version__``, plus ``git describe`` of the source tree when it is a git checkout."""
    try:
        described = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--tags"],
            cwd=Path(__file__).resolve().parent,
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return __version__
    tag = described.stdout.strip()
    return f"{__version__}+{tag}" if described.returncode == 0 and tag else __version__


def trained_patterns(record: dict) -> list[str]:
    """The jitter patterns a checkpoint was trained on: its record's ``jitter_pattern`` holds one
    name, or several joined by commas when the training sets used several (``train.run``).  By
    today's names: a record written before a pattern was renamed (the shipped ones say ``mnss`` for
    ``grid``) reads as the new name, without a warning, since the file is not the user's to change."""
    return list(dict.fromkeys(pattern_name(p) for p in str(record.get("jitter_pattern") or "").split(",") if p))


def bundle_pattern(record: dict, scale=None) -> str:
    """The jitter pattern a bundle of this checkpoint asks the engine for: the toolkit's grid
    pattern when it was trained on it (or the record names none), else the first it was trained on.
    At a ``scale`` the grid has no order for (a quality mode such as 1.7), Halton in its place."""
    from ..ops.jitter import GRID_SCALES

    patterns = trained_patterns(record)
    if scale is not None and float(scale) not in GRID_SCALES:
        usable = [p for p in patterns if p != "grid"]
        return "halton" if not usable or "halton" in usable else usable[0]
    return "grid" if not patterns or "grid" in patterns else patterns[0]


def make_record(model: nn.Module, record: dict | None = None) -> dict:
    """The full record for ``model``: the caller's ``jitter_pattern``, ``data_fingerprint`` and
    ``training`` (others in ``record`` are kept too) plus everything derived from the model."""
    record = dict(record or {})
    macs = count_macs(model).to_dict()
    derived = {
        "format": FORMAT_TAG,
        "version": FORMAT_VERSION,
        "family": model.config.family,
        "config": to_dict(model.config),
        "scale": model.scale,
        "code_version": code_version(),
        "macs": macs,
        "macs_per_pixel": macs["macs_per_pixel"],
        "params": macs["params"],
    }
    out = {key: record.get(key) for key in CALLER_KEYS}
    out.update({k: v for k, v in record.items() if k not in derived})
    out.update(derived)
    _check_plain(out, "record")
    return out


def save(path: str | Path, model: nn.Module, record: dict | None = None) -> Path:
    """Write ``model`` and its record to ``path`` atomically; returns the path."""
    payload = {"record": make_record(model, record), "state_dict": {k: v.detach().cpu() for k, v in model.state_dict().items()}}
    with atomic_output_path(path) as tmp:
        torch.save(payload, tmp)
    return Path(path)


def resolve(path_or_name: str | Path) -> Path:
    """A checkpoint file, the shipped ``mnss_kit/zoo/<name>.pt`` for a bare name, or the checkpoint
    a ``size.json`` of ``mnss-kit size`` chose."""
    path = Path(path_or_name)
    if path.is_file() and path.suffix == ".json":
        from ..size.choice import read_choice

        return read_choice(path)
    if path.is_file():
        return path
    shipped = ZOO_DIR / f"{path_or_name}.pt"
    if path.parent == Path(".") and shipped.is_file():
        return shipped
    names = ", ".join(shipped_names()) or "none shipped"
    raise UserError(f"no checkpoint '{path_or_name}' (a .pt path, or a shipped name: {names})")


def shipped_names() -> list[str]:
    """Names of the checkpoints in ``mnss_kit/zoo``, sorted."""
    return sorted(p.stem for p in ZOO_DIR.glob("*.pt"))


def read_record(path_or_name: str | Path) -> tuple[dict, dict]:
    """``(record, state_dict)`` of a checkpoint, after checking it is one this toolkit can read."""
    path = resolve(path_or_name)
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # torch raises several types for a truncated or foreign file
        raise UserError(f"{path} is not a readable mnss-kit checkpoint ({type(e).__name__})") from None
    record = payload.get("record") if isinstance(payload, dict) else None
    if not isinstance(record, dict) or record.get("format") != FORMAT_TAG or "state_dict" not in payload:
        raise UserError(f"{path} is not an mnss-kit checkpoint")
    version = record.get("version")
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise UserError(f"{path} is checkpoint version {version}; this mnss-kit reads up to {FORMAT_VERSION} (upgrade mnss-kit)")
    return record, payload["state_dict"]


def load(path_or_name: str | Path) -> tuple[nn.Module, dict]:
    """``(model in eval mode, record)`` from a checkpoint path or a shipped name."""
    record, state_dict = read_record(path_or_name)
    _check_finite(state_dict, path_or_name)
    config = model_config_from_dict(record.get("config"), source=f"{path_or_name} record")
    model = build_model(config)
    try:
        model.load_state_dict(state_dict)
    except RuntimeError as e:
        first = str(e).strip().splitlines()[-1].strip()
        raise UserError(f"{path_or_name}: weights do not match the recorded config ({first})") from None
    return model.eval(), record


def digest(path_or_name: str | Path) -> str:
    """SHA-256 of the checkpoint file: a model retrained under the same name is another model."""
    return sha256_file(resolve(path_or_name))


def identity(path_or_name: str | Path, record: dict) -> dict:
    """What a derived artefact records about the checkpoint it came from: path, SHA-256 of the file,
    family, scale, config and code version (plain data)."""
    return {
        "path": str(path_or_name),
        "sha256": digest(path_or_name),
        "family": record.get("family"),
        "scale": record.get("scale"),
        "config": record.get("config"),
        "code_version": record.get("code_version"),
    }


def _check_finite(state_dict: dict, source) -> None:
    """A NaN or Inf weight spreads through every frame it touches (and through the recurrent
    history into all later ones): refuse it, naming the first such tensor."""
    for name, tensor in state_dict.items():
        if torch.is_tensor(tensor) and torch.is_floating_point(tensor):
            bad = int((~torch.isfinite(tensor)).sum())
            if bad:
                raise UserError(f"{source}: weight '{name}' holds {bad} NaN or Inf value{'s' if bad != 1 else ''} "
                                f"of {tensor.numel()}")


def _check_plain(value, where: str) -> None:
    """Records must be plain data so that ``weights_only=True`` can load them."""
    if not isinstance(value, PLAIN_TYPES):
        raise TypeError(f"checkpoint {where} holds a {type(value).__name__}; records take plain data only")
    if isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, str):
                raise TypeError(f"checkpoint {where} has a non-string key {k!r}")
            _check_plain(v, f"{where}.{k}")
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            _check_plain(v, f"{where}[{i}]")
