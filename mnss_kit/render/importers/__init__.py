"""Scene import: glTF 2.0 (.gltf, .glb) and Wavefront OBJ (+MTL) files -> world-space meshes.

``load_meshes(path)`` returns a list of ``mnss_kit.render.mesh.Mesh`` with every node transform
baked in (static geometry), UVs in the glTF convention (v grows downwards) and counter-clockwise
front faces.  What the file lacks is filled in (smooth normals, zero UVs, the material colour for
a texture that is not found) with one ``logging.warning`` per kind of fill-in naming the file.
Anything the toolkit cannot read raises ``UserError`` with one line naming the file.
"""

from __future__ import annotations

from pathlib import Path

from mnss_kit.errors import UserError
from mnss_kit.render.mesh import Mesh

SUPPORTED_SUFFIXES = (".gltf", ".glb", ".obj")


def load_meshes(path: str | Path) -> list[Mesh]:
    """Read a .gltf, .glb or .obj scene into world-space meshes, one per primitive (glTF
    node x primitive) or per material (OBJ)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise UserError(f"{path}: unsupported scene file type '{path.suffix}' (expected {', '.join(SUPPORTED_SUFFIXES)})")
    if not path.is_file():
        raise UserError(f"{path}: scene file not found")
    if suffix == ".obj":
        from mnss_kit.render.importers.obj import load_obj

        meshes = load_obj(path)
    else:
        from mnss_kit.render.importers.gltf import load_gltf

        meshes = load_gltf(path)
    if not meshes:
        raise UserError(f"{path}: no triangle geometry to render")
    return meshes


__all__ = ["SUPPORTED_SUFFIXES", "load_meshes"]
