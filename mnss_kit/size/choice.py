"""The size file's format and its choice: what ``mnss-kit export OUT/size.json`` (any command
that takes a checkpoint) resolves to.  No torch and no stage imports: ``model.checkpoint`` reads it."""

from __future__ import annotations

from pathlib import Path

from ..errors import UserError
from ..fileio import check_format, read_json

FORMAT, VERSION = "mnss-kit-size", 1


def read_choice(path: Path) -> Path:
    """The checkpoint a size file chose."""
    doc = read_json(path)
    check_format(doc, path, FORMAT, "version", VERSION, "a size file")
    choice = doc.get("choice")
    if not choice:
        raise UserError(f"{path}: no rung met the size targets, so there is no chosen model")
    checkpoint = path.parent / choice["checkpoint"]
    if not checkpoint.is_file():
        raise UserError(f"{path}: its chosen checkpoint {checkpoint} is missing")
    return checkpoint
