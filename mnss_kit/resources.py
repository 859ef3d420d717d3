"""Where the files shipped inside the package live: configs, schemas, shaders, checkpoints.

Found through ``importlib.resources`` so they are the same from a source checkout and from an
installed wheel; nothing looks for the repository root.  The toolkit reads them with ordinary
path operations (glob, includes relative to a shader), so the package must be installed as a
directory, which is what pip does with a wheel.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def package_dir(*parts: str) -> Path:
    """The directory ``mnss_kit/<parts...>`` of the installed package."""
    root = files(__package__)
    if not isinstance(root, Path):
        raise RuntimeError(f"mnss_kit must be installed as a directory, not inside an archive ({root})")
    return root.joinpath(*parts)


CONFIG_DIR = package_dir("configs")
SCHEMA_DIR = package_dir("schemas")
SHADER_DIR = package_dir("shaders")
ZOO_DIR = package_dir("zoo")
