"""The ``model:`` section of a model config file, and reading it.

A model config file (``mnss_kit/configs/models/NAME.yaml``)::

    schema: 1
    model:  {family: mnss, scale: 2, ...}   # this module; the family's config class reads the rest
    train:  {...}                           # read by the training stage, ignored here
    data:   {...}                           # read by the training stage, ignored here
"""

from __future__ import annotations

from pathlib import Path

from ..config import CONFIG_DIR, apply_overrides, from_dict, read_config_with_base, resolve_config_path
from ..errors import UserError

SCHEMA_VERSION = 1
TOP_LEVEL_KEYS = ("schema", "model", "train", "data")


DEFAULT_FAMILY = "mnss"  # a ``model:`` section without ``family``


def model_config_from_dict(section: dict, source: str = "model config"):
    """Validate a ``model:`` section (plain data) into its family's config dataclass."""
    from .families import FAMILIES

    if not isinstance(section, dict):
        raise UserError(f"{source}: 'model' must be a mapping")
    family = section.get("family", DEFAULT_FAMILY)
    if family not in FAMILIES:
        raise UserError(f"{source}: unknown model family '{family}' (one of: {', '.join(FAMILIES)})")
    return from_dict(FAMILIES[family].config, section, where="model", source=source)


def describes(saved, config) -> bool:
    """Whether a checkpoint record's ``model:`` section ``saved`` is ``config``: parsed, so a key the
    section gained after the record was written reads as its default."""
    try:
        return model_config_from_dict(saved) == config
    except UserError:  # from_dict turns every bad value into one
        return False


def load_model_config(name_or_path: str | Path, overrides: list[str] | None = None):
    """Read the ``model:`` section of a config file (a path or a name under ``mnss_kit/configs/models``).

    ``overrides`` are ``--set`` items such as ``model.recon_width=64``.
    """
    path = resolve_config_path(str(name_or_path), "models")
    data = apply_overrides(read_config_with_base(path, "models"), overrides)
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
    """Names of the shipped model configs (``mnss_kit/configs/models/*.yaml``), sorted."""
    return sorted(p.stem for p in (CONFIG_DIR / "models").glob("*.yaml"))
