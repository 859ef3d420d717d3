"""Every name the scripts under scripts/, scripts/studies/ and benchmarks/ import exists: a script that runs for an hour
must not stop at its last step on an import a refactor left behind."""

from __future__ import annotations

import ast
import importlib
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
SCRIPTS = sorted((REPO / "scripts").glob("*.py")) + sorted((REPO / "scripts" / "studies").glob("*.py")) + sorted((REPO / "benchmarks").glob("*.py"))


def imported_names(path: Path) -> list[tuple[str, str | None, int]]:
    """``(module, name or None, line)`` of every import in ``path``, nested ones included."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(alias.name, None, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out += [(node.module, alias.name, node.lineno) for alias in node.names]
    return out


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_import_of_a_script_resolves(path, monkeypatch):
    for folder in (REPO, REPO / "benchmarks", REPO / "scripts", REPO / "scripts" / "studies"):
        monkeypatch.syspath_prepend(str(folder))
    missing = []
    for module, name, line in imported_names(path):
        if module.split(".")[0] not in sys.modules and importlib.util.find_spec(module.split(".")[0]) is None:
            missing.append(f"line {line}: no module {module}")
            continue
        target = importlib.import_module(module)
        if name is not None and name != "*" and not hasattr(target, name):
            try:
                importlib.import_module(f"{module}.{name}")
            except ImportError:
                missing.append(f"line {line}: {module} has no {name}")
    assert not missing, missing
