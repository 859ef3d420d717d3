"""Runtime shader sources: reading them from package data and flattening their ``#include`` lines.

GLSL ES has no ``#include``.  The runtime passes (``mnss_kit/shaders/runtime``) are entry files
(``*_pass.comp``: version, bindings, workgroup size, ``main``) that include binding-free
algorithm files (``*.glsl``).  :func:`flatten` splices the includes in, each file once (the
first time it is reached, like ``#pragma once``), so the result is one ES 3.10 compute shader:
what the Mesa harness compiles and what the bundle exporter ships to the phone.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

from ..resources import SHADER_DIR

RUNTIME_SHADER_DIR = SHADER_DIR / "runtime"
INCLUDE_LINE = re.compile(r'^[ \t]*#[ \t]*include[ \t]+"([^"]+)"[ \t]*(?://.*)?$', re.M)
VERSION_LINE = "#version 310 es"


def shader_path(name: str, directory: Path = RUNTIME_SHADER_DIR) -> Path:
    """Path of runtime shader file ``name`` (e.g. ``"warp_pass.comp"``); ``FileNotFoundError`` if absent."""
    path = directory / name
    if not path.is_file():
        raise FileNotFoundError(f"no shader file {name!r} in {directory}")
    return path


def flatten_text(text: str, directory: Path = RUNTIME_SHADER_DIR, included: set[str] | None = None) -> str:
    """``text`` with every ``#include "file"`` replaced by that file (from ``directory``), recursively.

    A file already spliced in (anywhere in the result) is replaced by a comment, so shared helpers
    appear once and include cycles end.
    """
    seen = set() if included is None else included

    def splice(match: re.Match) -> str:
        name = match.group(1)
        if name in seen:
            return f"// (already included: {name})"
        seen.add(name)
        body = flatten_text(shader_path(name, directory).read_text(), directory, seen)
        return f"// ---- begin {name}\n{body.rstrip()}\n// ---- end {name}"

    return INCLUDE_LINE.sub(splice, text)


def flatten(name: str, directory: Path = RUNTIME_SHADER_DIR) -> str:
    """The complete source of entry file ``name``, includes spliced in; starts with ``#version 310 es``."""
    text = flatten_text(shader_path(name, directory).read_text(), directory)
    if not text.startswith(VERSION_LINE):
        raise ValueError(f"{name}: a runtime entry file must start with '{VERSION_LINE}'")
    return text


def source_hash(text: str) -> str:
    """SHA-256 (hex) of a flattened source, for the bundle manifest."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
