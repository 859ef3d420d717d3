"""Every data file inside the package ships in the wheel: pyproject's package-data globs cover it."""

import fnmatch
import tomllib
from pathlib import Path

from mnss_kit import resources

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "mnss_kit"


def test_every_data_file_is_declared_package_data():
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["mnss_kit"]
    data = [p.relative_to(PKG).as_posix() for p in PKG.rglob("*")
            if p.is_file() and p.suffix not in (".py", ".pyc") and "__pycache__" not in p.parts]
    assert data, "no package data found"
    missing = [f for f in data if not any(fnmatch.fnmatch(f, g) for g in globs)]
    assert not missing, f"not in [tool.setuptools.package-data]: {missing}"


def test_package_data_is_found_inside_the_package():
    for directory in (resources.CONFIG_DIR, resources.SCHEMA_DIR, resources.SHADER_DIR, resources.ZOO_DIR):
        assert directory.is_dir() and directory.parent == PKG, directory
