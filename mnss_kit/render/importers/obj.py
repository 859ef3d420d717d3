"""Wavefront OBJ (+MTL) reader -> meshes, one per material, in the glTF conventions.

OBJ: ``v``, ``vt``, ``vn``, ``f`` (polygons split into fans from their first corner; negative
indices count back from the last vertex read; corners may lack ``vt`` or ``vn``), ``usemtl`` and
``mtllib``.  Groups and smoothing groups are ignored.  Faces of fewer than 3 corners (Blender
writes its loose edges as two-corner ``f`` lines), lines (``l``) and points (``p``) are no
surfaces: they are skipped and counted in one warning per file, as other importers do.  Texture
``v`` is flipped (v_gltf = 1 - v_obj) because OBJ's v grows upwards.

MTL, each mapped onto ``Material``:
- ``Kd``: linear base colour.  A ``map_Kd`` texture that loads replaces it (base colour becomes
  white), as Blender reads OBJ files; when the texture is missing, ``Kd`` stays.
- ``Ke``: linear emissive colour.
- ``Ns`` (Phong exponent, 0..1000) -> roughness = 1 - sqrt(Ns / 1000): the inverse of what
  Blender's OBJ exporter writes (Ns = 1000 (1 - roughness)^2), so its files keep their roughness.
  ``Pr``/``Pm`` (the PBR extension) set roughness/metallic directly and win over ``Ns``.
- ``d`` (or ``Tr`` = 1 - d) below 1 -> alpha mode "blend", the alpha carried by the texture.
- ``map_d`` -> alpha mode "mask" with the map's alpha (or grey) values as the texture's alpha.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mnss_kit.errors import UserError
from mnss_kit.render.importers.common import FillIns, bake_alpha, decode_image, log, normalize_rows, smooth_normals
from mnss_kit.render.mesh import Material, Mesh

# Texture map options and how many arguments they take; None: one to three numbers.
MAP_OPTIONS = {"-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1, "-imfchan": 1,
               "-texres": 1, "-type": 1, "-mm": 2, "-o": None, "-s": None, "-t": None}  # fmt: skip
MAX_SHININESS = 1000.0


def load_obj(path: Path) -> list[Mesh]:
    """Meshes of an OBJ file, one per material used by its faces, in order of first use."""
    reader = _ObjReader(path)
    reader.parse()
    meshes = reader.meshes()
    reader.fill_ins.emit()
    reader.warn_skipped()
    return meshes


def roughness_from_shininess(shininess: float) -> float:
    """MTL ``Ns`` (0..1000) -> roughness in [0, 1]; see the module docstring."""
    return float(1.0 - np.sqrt(np.clip(shininess, 0.0, MAX_SHININESS) / MAX_SHININESS))


@dataclass
class _FaceGroup:
    """Faces sharing a material: unique (position, texcoord, normal) corners and triangles."""

    corner_ids: dict[tuple[int, int, int], int] = field(default_factory=dict)
    token_ids: dict[str, int] = field(default_factory=dict)  # "3/1/2" -> vertex id, a shortcut
    triangles: list[tuple[int, int, int]] = field(default_factory=list)

    def vertex(self, corner: tuple[int, int, int]) -> int:
        return self.corner_ids.setdefault(corner, len(self.corner_ids))


class _ObjReader:
    def __init__(self, path: Path):
        self.path = path
        self.fill_ins = FillIns(path)
        self.positions: list[list[float]] = []
        self.texcoords: list[list[float]] = []
        self.normals: list[list[float]] = []
        self.groups: dict[str, _FaceGroup] = {}
        self.material_records: dict[str, dict] = {}
        self._images: dict[Path, np.ndarray | None] = {}
        self.skipped = {"face(s) of fewer than 3 corners": 0, "line(s)": 0, "point(s)": 0}

    def parse(self) -> None:
        material = ""
        for where, keyword, args in _statements(self.path):
            if keyword == "v":
                self.positions.append(_numbers(args, 3, 3, where, keyword))
            elif keyword == "vt":
                u, v = (_numbers(args, 1, 2, where, keyword) + [0.0])[:2]
                self.texcoords.append([u, v])
            elif keyword == "vn":
                self.normals.append(_numbers(args, 3, 3, where, keyword))
            elif keyword == "f":
                self._face(args, self.groups.setdefault(material, _FaceGroup()), where)
            elif keyword in ("l", "p"):
                self.skipped["line(s)" if keyword == "l" else "point(s)"] += 1
            elif keyword == "usemtl":
                material = " ".join(args)
            elif keyword == "mtllib":
                self._material_libraries(args)

    def _face(self, args: list[str], group: _FaceGroup, where: str) -> None:
        if len(args) < 3:
            self.skipped["face(s) of fewer than 3 corners"] += 1
            return
        ids = []
        for token in args:
            vertex_id = group.token_ids.get(token)
            if vertex_id is None:
                vertex_id = group.vertex(self._corner(token, where))
                if "-" not in token:  # positive indices mean the same corner on every line
                    group.token_ids[token] = vertex_id
            ids.append(vertex_id)
        group.triangles.extend((ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1))

    def warn_skipped(self) -> None:
        counts = [f"{n} {what}" for what, n in self.skipped.items() if n]
        if counts:
            log.warning("%s: skipped %s: no surface to render", self.path, ", ".join(counts))

    def _corner(self, token: str, where: str) -> tuple[int, int, int]:
        """0-based (position, texcoord, normal) indices of a face corner 'v', 'v/t', 'v//n' or 'v/t/n'; -1: absent."""
        fields = token.split("/")
        position = _resolve(fields[0], len(self.positions), where, "vertex")
        texcoord = _resolve(fields[1], len(self.texcoords), where, "texture") if len(fields) > 1 and fields[1] else -1
        normal = _resolve(fields[2], len(self.normals), where, "normal") if len(fields) > 2 and fields[2] else -1
        return position, texcoord, normal

    def meshes(self) -> list[Mesh]:
        positions = np.array(self.positions, dtype=np.float64).reshape(-1, 3)
        texcoords = np.array(self.texcoords, dtype=np.float64).reshape(-1, 2)
        normals = np.array(self.normals, dtype=np.float64).reshape(-1, 3)
        meshes = []
        for name, group in self.groups.items():
            label = name or "default"
            corners = np.array(list(group.corner_ids), dtype=np.int64).reshape(-1, 3)  # -1: absent
            triangles = np.array(group.triangles, dtype=np.int64).reshape(-1, 3)
            mesh_positions = positions[corners[:, 0]]
            meshes.append(
                Mesh(
                    mesh_positions,
                    self._vertex_normals(mesh_positions, triangles, normals, corners[:, 2], label),
                    self._vertex_uvs(texcoords, corners[:, 1], label),
                    triangles,
                    self._material(name),
                    name=label,
                )
            )
        return meshes

    def _vertex_normals(self, positions, triangles, normals, normal_ids, label) -> np.ndarray:
        present = normal_ids >= 0
        if present.all():
            return normalize_rows(normals[normal_ids])
        self.fill_ins.note("no vn, computed area-weighted smooth normals", label)
        out = smooth_normals(positions, triangles)
        out[present] = normalize_rows(normals[normal_ids[present]])
        return out

    def _vertex_uvs(self, texcoords, texcoord_ids, label) -> np.ndarray:
        present = texcoord_ids >= 0
        if not present.all():
            self.fill_ins.note("no vt, texture coordinates filled with (0, 0)", label)
        uvs = np.zeros((len(texcoord_ids), 2))
        uvs[present] = texcoords[texcoord_ids[present]]
        uvs[present, 1] = 1.0 - uvs[present, 1]  # OBJ v grows upwards, glTF v downwards
        return uvs

    # --- materials ---------------------------------------------------------------------------

    def _material_libraries(self, args: list[str]) -> None:
        whole = " ".join(args)  # a single name with spaces, or several names
        for name in [whole] if (self.path.parent / whole).is_file() else args:
            file = self.path.parent / name.replace("\\", "/")
            if file.is_file():
                self._parse_mtl(file)
            else:
                self.fill_ins.note("material library not found, used default materials", name)

    def _parse_mtl(self, file: Path) -> None:
        record = None
        for where, keyword, args in _statements(file):
            if keyword == "newmtl":
                record = self.material_records[" ".join(args)] = {"directory": file.parent}
            elif record is None:
                continue
            elif keyword in ("Kd", "Ke"):
                values = _numbers(args, 1, 3, where, keyword)
                record[keyword] = tuple(values * 3 if len(values) == 1 else values[:3])  # "Kd 0.5" is grey
            elif keyword in ("Ns", "Pr", "Pm"):
                record[keyword] = _numbers(args[-1:], 1, 1, where, keyword)[0]
            elif keyword in ("d", "Tr"):  # the later one wins; "d -halo 0.5" keeps the number
                alpha = _numbers(args[-1:], 1, 1, where, keyword)[0]
                record["alpha"] = alpha if keyword == "d" else 1.0 - alpha
            elif keyword in ("map_Kd", "map_d"):
                record[keyword] = _map_file(args, where)

    def _material(self, name: str) -> Material:
        record = self.material_records.get(name)
        if record is None:
            if name:
                self.fill_ins.note("materials not defined in any material library, used the default", name)
            return Material(name=name)
        default = Material()
        color_map = self._image(record, "map_Kd")
        texture, alpha_mode = color_map, "opaque"
        if "map_d" in record:
            coverage = self._image(record, "map_d")
            if coverage is not None:
                texture, alpha_mode = self._with_coverage(texture, coverage, name), "mask"
        alpha = float(record.get("alpha", 1.0))
        if alpha < 1.0:
            texture, alpha_mode = bake_alpha(texture, alpha), "blend"
        if "Pr" in record:
            roughness = float(np.clip(record["Pr"], 0.0, 1.0))
        else:
            roughness = roughness_from_shininess(record["Ns"]) if "Ns" in record else default.roughness
        return Material(
            base_color=(1.0, 1.0, 1.0) if color_map is not None else record.get("Kd", default.base_color),
            base_color_texture=texture,
            roughness=roughness,
            metallic=float(np.clip(record.get("Pm", 0.0), 0.0, 1.0)),
            emissive=record.get("Ke", default.emissive),
            alpha_mode=alpha_mode,
            name=name,
        )

    def _with_coverage(self, texture: np.ndarray | None, coverage: np.ndarray, name: str) -> np.ndarray:
        """Texture with ``map_d`` values (its alpha, or grey level) as alpha, (H, W, 4) uint8."""
        alpha = coverage[..., 3] if coverage.shape[2] == 4 else coverage[..., 0]
        if texture is None:
            texture = np.full(alpha.shape + (3,), 255, dtype=np.uint8)
        if texture.shape[:2] != alpha.shape:
            self.fill_ins.note("map_d ignored, its size differs from map_Kd", name)
            return texture
        return np.concatenate([texture[..., :3], alpha[..., None]], axis=2)

    def _image(self, record: dict, key: str) -> np.ndarray | None:
        if key not in record:
            return None
        file = record["directory"] / record[key].replace("\\", "/")
        if file not in self._images:
            if file.is_file():
                self._images[file] = decode_image(file.read_bytes(), str(file))
            else:
                self.fill_ins.note("texture file not found, used the material's Kd colour", record[key])
                self._images[file] = None
        return self._images[file]


def _statements(file: Path):
    """Yields ("file:line", keyword, arguments) per statement, joining '\\' continuations."""
    pending, start = "", 1
    for number, raw in enumerate(file.read_bytes().decode("utf-8", errors="replace").splitlines(), 1):
        if not pending:
            start = number
        if raw.rstrip().endswith("\\"):
            pending += raw.rstrip()[:-1] + " "
            continue
        tokens = (pending + raw).split("#", 1)[0].split()
        pending = ""
        if tokens:
            yield f"{file}:{start}", tokens[0], tokens[1:]


def _numbers(args: list[str], minimum: int, maximum: int, where: str, keyword: str) -> list[float]:
    """The first ``maximum`` arguments as floats; at least ``minimum`` must be there."""
    try:
        values = [float(a) for a in args[:maximum]]
    except ValueError:
        raise UserError(f"{where}: '{keyword}' expects numbers, got '{' '.join(args)}'") from None
    if len(values) < minimum:
        raise UserError(f"{where}: '{keyword}' expects at least {minimum} numbers, got {len(values)}")
    return values


def _resolve(token: str, count: int, where: str, kind: str) -> int:
    """0-based index of a 1-based (or negative, counted back from the end) OBJ index."""
    try:
        index = int(token)
    except ValueError:
        raise UserError(f"{where}: '{token}' is not a {kind} index") from None
    resolved = index - 1 if index > 0 else count + index
    if index == 0 or not 0 <= resolved < count:
        raise UserError(f"{where}: {kind} index {index} is out of range ({count} defined before this line)")
    return resolved


def _map_file(args: list[str], where: str) -> str:
    """File name of a texture map statement, past its options."""
    k = 0
    while k < len(args) and args[k] in MAP_OPTIONS:
        arity = MAP_OPTIONS[args[k]]
        k += 1
        if arity is None:  # one to three numbers
            taken = 0
            while taken < 3 and k < len(args) and _is_number(args[k]):
                k, taken = k + 1, taken + 1
        else:
            k += arity
    if k >= len(args):
        raise UserError(f"{where}: texture map without a file name")
    return " ".join(args[k:])


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
