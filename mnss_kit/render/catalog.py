"""Props from an installed furniture catalogue: real meshes with photographic textures, for the
catalogue scenes (``scenes/rooms.py``).

The catalogue is Sweet Home 3D's "Blend Swap CC-0" furniture library, which Debian ships in the
package ``sweethome3d-furniture`` (CC0; docs/assets.md lists what it holds and its licence): a
zip (``.sh3f``) of OBJ/MTL models with JPEG and PNG textures, and a properties file giving each
model's name, category and size in centimetres.  ``MNSS_KIT_CATALOG`` names another ``.sh3f``.

Every prop belongs to one split by a hash of its id: ``train`` (the scenes training data is
rendered from) or ``unseen`` (the held-out scenes).  An unseen prop whose texture bytes also
belong to a training prop is left out, so no mesh and no texture of an unseen scene is ever
trained on.
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
import shutil
import tempfile
import zipfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import UserError
from . import shapes
from .mesh import Mesh

DEFAULT_CATALOG = Path("/usr/share/sweethome3d/furniture/BlendSwap-CC-0.sh3f")
SPLITS = ("train", "unseen")
UNSEEN_SHARE = 3  # one prop in three is held out
MAX_OBJ_BYTES = 500_000  # larger models take seconds each to parse; the scenes use the lighter ones
MAX_SIZE_M = 3.5  # props larger than a room's wall are left out
IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png")


@dataclass(frozen=True)
class Prop:
    id: str
    name: str
    category: str
    model: str  # the OBJ file's path inside the catalogue
    size: tuple[float, float, float]  # width (x), height (y), depth (z) in metres
    elevation: float  # metres above the floor (wall lights, shelves)
    rotation: tuple[float, ...] | None  # row-major 3x3 applied to the model before sizing
    creator: str

    @property
    def folder(self) -> str:
        return self.model.rsplit("/", 1)[0] + "/"


def catalog_path() -> Path:
    path = Path(os.environ.get("MNSS_KIT_CATALOG", DEFAULT_CATALOG))
    if not path.is_file():
        raise UserError(f"furniture catalogue {path} not found: the catalogue scenes need it "
                        "(apt-get install sweethome3d-furniture, or set MNSS_KIT_CATALOG to a .sh3f file)")
    return path


def read_properties(text: str) -> dict[int, dict[str, str]]:
    """``key#N=value`` lines of a catalogue's properties file -> ``{N: {key: value}}``."""
    entries: dict[int, dict[str, str]] = {}
    for line in text.splitlines():
        match = re.fullmatch(r"(\w+)#(\d+)=(.*)", line.strip())
        if match:
            entries.setdefault(int(match[2]), {})[match[1]] = match[3]
    return entries


def split_of(prop_id: str) -> str:
    return "unseen" if hashlib.sha256(prop_id.encode()).digest()[0] % UNSEEN_SHARE == 0 else "train"


@lru_cache(maxsize=4)
def _catalog(path: Path) -> tuple[dict[str, list[Prop]], dict[str, list[tuple[str, str]]]]:
    """Props per split, and each prop's texture files as ``(name in the zip, SHA-256)`` sorted by
    name, of a catalogue."""
    try:
        with zipfile.ZipFile(path) as archive:
            infos = {i.filename: i for i in archive.infolist()}
            entries = read_properties(archive.read("PluginFurnitureCatalog.properties").decode("latin-1"))
            props, textures = [], {}
            for entry in entries.values():
                prop = _prop(entry)
                info = infos.get(prop.model)
                if info is None or info.file_size > MAX_OBJ_BYTES or max(prop.size) > MAX_SIZE_M:
                    continue
                props.append(prop)
                textures[prop.id] = [(n, hashlib.sha256(archive.read(n)).hexdigest()) for n in sorted(infos)
                                     if n.startswith(prop.folder) and n.lower().endswith(IMAGE_SUFFIXES)]
    except (zipfile.BadZipFile, KeyError, ValueError, OSError) as error:
        raise UserError(f"furniture catalogue {path}: unreadable ({error})") from None
    by_split = {s: [p for p in props if split_of(p.id) == s] for s in SPLITS}
    trained = {h for p in by_split["train"] for _, h in textures[p.id]}
    by_split["unseen"] = [p for p in by_split["unseen"] if not trained.intersection(h for _, h in textures[p.id])]
    return by_split, textures


def _prop(entry: dict[str, str]) -> Prop:
    rotation = tuple(float(v) for v in entry["modelRotation"].split()) if "modelRotation" in entry else None
    size = tuple(float(entry[k]) / 100.0 for k in ("width", "height", "depth"))
    return Prop(entry["id"], entry.get("name", ""), entry.get("category", ""), entry["model"].lstrip("/"), size,
                float(entry.get("elevation", 0.0)) / 100.0, rotation, entry.get("creator", ""))


def props(split: str) -> list[Prop]:
    """The props of one split, in catalogue order."""
    if split not in SPLITS:
        raise ValueError(f"split must be one of {SPLITS}, got {split!r}")
    return list(_catalog(catalog_path())[0][split])


def texture_hashes(prop: Prop) -> list[str]:
    """SHA-256 of each texture file in the prop's folder."""
    return [digest for _, digest in _catalog(catalog_path())[1][prop.id]]


def surface_textures(split: str, min_size: int = 256) -> list[np.ndarray]:
    """The split's texture images at least ``min_size`` pixels on each side, (H, W, 3) uint8 sRGB,
    each once: photographs of wood, stone, fabric and metal for floors and walls."""
    from .importers.common import decode_image

    path, seen, images = catalog_path(), set(), []
    textures = _catalog(path)[1]
    with zipfile.ZipFile(path) as archive:
        for prop in props(split):
            for name, digest in textures[prop.id]:
                if digest in seen:
                    continue
                seen.add(digest)
                image = decode_image(archive.read(name), f"{path}:{name}")
                if min(image.shape[:2]) >= min_size:
                    images.append(image[..., :3])
    return images


def prop_meshes(prop: Prop) -> list[Mesh]:
    """The prop's meshes, as Sweet Home 3D places them: rotated, scaled to the catalogue size,
    centred on x and z, standing on y = 0 (plus its elevation)."""
    return [shapes.transform(m, fit) for m, fit in _loaded(catalog_path(), prop)]


@lru_cache(maxsize=256)
def _loaded(path: Path, prop: Prop) -> tuple[tuple[Mesh, np.ndarray], ...]:
    from .importers.obj import load_obj  # imported when a catalogue scene is built

    importer_log = logging.getLogger("mnss_kit.render.importers")
    level = importer_log.level
    importer_log.setLevel(logging.ERROR)  # the catalogue's fill-ins (no normals, missing maps) are known
    try:
        meshes = load_obj(_extracted(path, prop.folder) / prop.model)
    finally:
        importer_log.setLevel(level)
    rotation = np.eye(4)
    if prop.rotation is not None:
        rotation[:3, :3] = np.asarray(prop.rotation, np.float64).reshape(3, 3)
    points = np.concatenate([m.positions for m in meshes]).astype(np.float64) @ rotation[:3, :3].T
    lo, hi = points.min(axis=0), points.max(axis=0)
    extent = np.maximum(hi - lo, 1e-6)
    scale = np.diag([*(np.asarray(prop.size) / extent), 1.0])
    centre = shapes.translate(-(lo[0] + hi[0]) / 2, -lo[1], -(lo[2] + hi[2]) / 2)
    fit = shapes.translate(0.0, prop.elevation, 0.0) @ scale @ centre @ rotation
    return tuple((m, fit) for m in meshes)


def _extracted(path: Path, folder: str) -> Path:
    """The catalogue's ``folder`` unpacked in the user's cache (once; atomic, so an interrupted
    unpack is never read)."""
    stat = path.stat()
    key = hashlib.sha256(f"{path.resolve()}:{stat.st_size}:{stat.st_mtime_ns}".encode()).hexdigest()[:16]
    root = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "mnss-kit" / "catalog" / key
    target = root / folder
    if target.is_dir():
        return root
    target.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=target.parent, prefix=".unpack-"))
    try:
        with zipfile.ZipFile(path) as archive:
            for name in archive.namelist():
                if name.startswith(folder) and not name.endswith("/"):
                    archive.extract(name, staging)
        try:
            os.replace(staging / folder, target)
        except OSError:  # another process unpacked it first
            if not target.is_dir():
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return root
