"""The bundle manifest: format constants, reading with the version gate, schema validation, file hashes.

``manifest.json`` is the one file a reader opens first.  It carries ``format`` (always
:data:`FORMAT`) and ``format_version`` (an integer raised whenever a reader written for the
previous version could misread a bundle).  A reader refuses a newer version instead of guessing.
Every other file of the bundle is listed under ``files`` with its size and SHA-256, so a copy
can be verified without knowing what each file is for.  The JSON schema that ships with the
toolkit (``mnss_kit/schemas/manifest.schema.json``) describes the rest; ``docs/bundle.md``
explains it for an engine integrator.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from ..errors import UserError
from ..fileio import check_format, read_json, sha256_file
from ..resources import SCHEMA_DIR

FORMAT = "mnss-kit-bundle"
FORMAT_VERSION = 1
MANIFEST_NAME = "manifest.json"
SCHEMA_PATH = SCHEMA_DIR / "manifest.schema.json"


class NewerFormatError(UserError):
    """The bundle was written by a newer mnss-kit whose format this one cannot read."""


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def bundle_files(root: Path) -> list[str]:
    """Every regular file under ``root`` except the manifest, as sorted POSIX relative paths."""
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file() and p.name != MANIFEST_NAME)


def file_table(root: Path) -> dict[str, dict]:
    """``{relative path: {"bytes": n, "sha256": hex}}`` of every file of the bundle but the manifest."""
    return {name: {"bytes": (root / name).stat().st_size, "sha256": sha256_file(root / name)} for name in bundle_files(root)}


def load_schema() -> dict:
    return json.loads(SCHEMA_PATH.read_text())


def read_manifest(bundle: Path) -> dict:
    """The parsed manifest of ``bundle`` after the format and version gate (not yet schema-checked).

    Raises ``UserError`` (one line, naming the file) for a missing or unparsable manifest or a
    foreign format, and :class:`NewerFormatError` for a newer format version.
    """
    path = Path(bundle) / MANIFEST_NAME
    if not Path(bundle).is_dir():
        raise UserError(f"bundle directory not found: {bundle}")
    if not path.is_file():
        raise UserError(f"{path}: missing (not an mnss-kit bundle)")
    data = read_json(path)
    check_format(data, path, FORMAT, "format_version", FORMAT_VERSION, "an mnss-kit bundle manifest", NewerFormatError)
    return data


def schema_problems(manifest: dict) -> list[str]:
    """One line per violation of the manifest schema, naming the JSON path."""
    import jsonschema

    validator = jsonschema.Draft202012Validator(load_schema())
    problems = []
    for error in sorted(validator.iter_errors(manifest), key=lambda e: list(map(str, e.absolute_path))):
        where = "/".join(str(p) for p in error.absolute_path) or "<top>"
        problems.append(f"manifest.json: schema: at '{where}': {_short(error.message)}")
    return problems


def _short(message: str, limit: int = 160) -> str:
    message = " ".join(message.split())
    return message if len(message) <= limit else message[: limit - 3] + "..."
