"""What the split stage takes, shared with export and size: the output size (its text, default and
limits) and the model to place (light at import)."""

from __future__ import annotations

from pathlib import Path

DEFAULT_RESOLUTION = (1280, 720)  # output (HR) size the estimates and bundles are made for
DEFAULT_RESOLUTION_TEXT = f"{DEFAULT_RESOLUTION[0]}x{DEFAULT_RESOLUTION[1]}"
# Largest output side accepted: 8K UHD fits; a frame beyond it exceeds what phone GPUs allocate as
# one texture (a 16384-wide HR history alone would be 2 GiB of rgba16f) and any display they drive.
MAX_OUTPUT_SIDE = 8192


def parse_resolution(text: str, option: str = "--resolution") -> tuple[int, int]:
    """``"1280x720"`` -> ``(1280, 720)``; ``option`` is the flag the errors name."""
    from ..errors import UserError

    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise UserError(f"{option} must look like 1280x720, got '{text}'")
    w, h = (int(p) for p in parts)
    if w < 1 or h < 1:
        raise UserError(f"{option} must be positive, got '{text}'")
    if max(w, h) > MAX_OUTPUT_SIDE:
        raise UserError(f"{option} {text}: at most {MAX_OUTPUT_SIDE} pixels a side (8K UHD is 7680x4320); "
                        "no device profile's GPU holds a larger frame")
    return w, h


def require_scale_multiple(size: tuple[int, int], scale: int) -> None:
    """The one rule for an output (HR) size, in every command that takes one: whole LR pixels."""
    from ..errors import UserError

    w, h = size
    if w % scale or h % scale:
        raise UserError(f"output size {w}x{h} is not a multiple of the model's scale {scale} "
                        f"(e.g. {w // scale * scale or scale}x{h // scale * scale or scale})")


def load_model(name_or_path: str):
    """``(model, label)`` from a checkpoint (path or shipped name), else from a model config."""
    from ..errors import UserError
    from ..model import checkpoint
    from ..model.config import config_names, load_model_config
    from ..model.families import build_model

    path = Path(name_or_path)
    if path.suffix != ".yaml" and (path.is_file() or name_or_path in checkpoint.shipped_names()):
        model, _ = checkpoint.load(name_or_path)
        return model, path.stem
    if path.suffix == ".yaml" or name_or_path in config_names():
        return build_model(load_model_config(name_or_path)).eval(), f"{path.stem} (config)"
    shipped = ", ".join(checkpoint.shipped_names()) or "none shipped"
    raise UserError(
        f"no model '{name_or_path}': give a checkpoint path, a shipped name ({shipped}) "
        f"or a model config ({', '.join(config_names())})"
    )

