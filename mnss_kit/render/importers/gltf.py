"""glTF 2.0 reader: .gltf (external or data-URI buffers) and .glb -> world-space meshes.

Reads the default scene's node tree (matrix or TRS), triangle list, strip and fan primitives
(points and lines are skipped with a warning; empty primitives silently), accessors of every
component type (normalized, strided, sparse) and the metallic-roughness material model.  Differences from a full viewer, each chosen because
``Material`` holds scalars: a metallicRoughnessTexture or emissiveTexture is reduced to its mean;
the base colour alpha factor is multiplied into the base colour texture's alpha channel when the
alpha mode is MASK or BLEND.  Missing normals become area-weighted smooth normals (the glTF
specification asks for flat ones; smooth normals suit the curved assets the toolkit trains on).
"""

from __future__ import annotations

import base64
import binascii
import json
import struct
import urllib.parse
from pathlib import Path

import numpy as np

from mnss_kit.errors import UserError
from mnss_kit.ops.colour import srgb_decode
from mnss_kit.render.importers.common import FillIns, bake_alpha, decode_image, normalize_rows, smooth_normals
from mnss_kit.render.mesh import Material, Mesh

GLB_MAGIC = b"glTF"
GLB_CHUNK_JSON = 0x4E4F534A
GLB_CHUNK_BIN = 0x004E4942
TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN = 4, 5, 6
COMPONENT_DTYPES = {
    5120: np.dtype("<i1"),
    5121: np.dtype("<u1"),
    5122: np.dtype("<i2"),
    5123: np.dtype("<u2"),
    5125: np.dtype("<u4"),
    5126: np.dtype("<f4"),
}
COMPONENT_COUNTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
SUPPORTED_EXTENSIONS = {"KHR_materials_emissive_strength", "KHR_texture_transform"}
ALPHA_MODES = ("OPAQUE", "MASK", "BLEND")


def load_gltf(path: Path) -> list[Mesh]:
    """Meshes of the default scene of a .gltf or .glb file, one per node x primitive."""
    document, glb_binary = _read_document(path)
    reader = _GltfReader(path, document, glb_binary)
    try:
        meshes = reader.meshes()
    except KeyError as error:
        raise UserError(f"{path}: malformed glTF, missing required property {error}") from None
    except (TypeError, ValueError, IndexError) as error:
        raise UserError(f"{path}: malformed glTF ({type(error).__name__}: {error})") from None
    reader.fill_ins.emit()
    return meshes


def _read_document(path: Path) -> tuple[dict, bytes | None]:
    data = path.read_bytes()
    glb_binary = None
    if path.suffix.lower() == ".glb" or data[:4] == GLB_MAGIC:
        data, glb_binary = _split_glb(path, data)
    try:
        document = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise UserError(f"{path}: invalid JSON ({error})") from None
    if not isinstance(document, dict):
        raise UserError(f"{path}: invalid glTF, the top-level JSON value is not an object")
    _check_version(path, document)
    unsupported = set(document.get("extensionsRequired", [])) - SUPPORTED_EXTENSIONS
    if unsupported:
        raise UserError(f"{path}: requires unsupported glTF extensions: {', '.join(sorted(unsupported))}")
    return document, glb_binary


def _split_glb(path: Path, data: bytes) -> tuple[bytes, bytes | None]:
    """(JSON chunk, BIN chunk or None) of a binary glTF."""
    if len(data) < 12:
        raise UserError(f"{path}: truncated .glb ({len(data)} bytes, shorter than the 12-byte header)")
    magic, version, length = struct.unpack_from("<4sII", data)
    if magic != GLB_MAGIC:
        raise UserError(f"{path}: not a binary glTF (magic {magic!r}, expected {GLB_MAGIC!r})")
    if version != 2:
        raise UserError(f"{path}: unsupported glTF version {version} (expected 2)")
    if length > len(data):
        raise UserError(f"{path}: truncated .glb (header says {length} bytes, file has {len(data)})")
    chunks = []
    offset = 12
    while offset < length:
        if offset + 8 > length:
            raise UserError(f"{path}: truncated .glb (chunk header at byte {offset} is cut off)")
        chunk_length, chunk_type = struct.unpack_from("<II", data, offset)
        offset += 8
        if offset + chunk_length > length:
            raise UserError(f"{path}: truncated .glb (chunk at byte {offset - 8} runs past the end)")
        chunks.append((chunk_type, data[offset : offset + chunk_length]))
        offset += chunk_length
    if not chunks or chunks[0][0] != GLB_CHUNK_JSON:
        raise UserError(f"{path}: invalid .glb, the first chunk is not JSON")
    binary = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == GLB_CHUNK_BIN else None
    return chunks[0][1], binary


def _check_version(path: Path, document: dict) -> None:
    asset = document.get("asset")
    version = str(asset.get("version", "")) if isinstance(asset, dict) else ""
    if version.split(".")[0] != "2":
        raise UserError(f"{path}: unsupported glTF version '{version}' (expected 2.x)")
    min_version = str(asset.get("minVersion", "2.0"))
    if min_version not in ("2", "2.0"):
        raise UserError(f"{path}: needs a glTF {min_version} reader (this one reads 2.0)")


class _GltfReader:
    def __init__(self, path: Path, document: dict, glb_binary: bytes | None):
        self.path = path
        self.document = document
        self.glb_binary = glb_binary
        self.fill_ins = FillIns(path)
        self._buffers: dict[int, bytes] = {}
        self._images: dict[int, np.ndarray | None] = {}
        self._materials: dict[int | None, tuple[Material, int, np.ndarray | None]] = {}

    def item(self, kind: str, index) -> dict:
        items = self.document.get(kind, [])
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(items):
            raise UserError(f"{self.path}: {kind}[{index}] is referenced but does not exist ({len(items)} defined)")
        return items[index]

    # --- scene graph -------------------------------------------------------------------------

    def meshes(self) -> list[Mesh]:
        meshes = []
        for node_index, world in self._world_transforms():
            node = self.item("nodes", node_index)
            if "mesh" not in node:
                continue
            mesh = self.item("meshes", node["mesh"])
            label = node.get("name") or mesh.get("name") or f"node {node_index}"
            for k, primitive in enumerate(mesh["primitives"]):
                built = self._primitive(primitive, world, f"{label}/{k}")
                if built is not None:
                    meshes.append(built)
        return meshes

    def _world_transforms(self):
        """Yields (node index, (4, 4) float64 world matrix) for every node of the default scene."""
        nodes = self.document.get("nodes", [])
        if self.document.get("scenes"):
            roots = self.item("scenes", self.document.get("scene", 0)).get("nodes", [])
        else:  # no scene: every root of the node forest
            children = {child for node in nodes for child in node.get("children", [])}
            roots = [i for i in range(len(nodes)) if i not in children]
        stack = [(root, np.eye(4)) for root in reversed(roots)]
        visits = 0
        while stack:
            index, parent = stack.pop()
            visits += 1
            if visits > len(nodes):
                raise UserError(f"{self.path}: the node hierarchy is not a tree (a cycle or a node with two parents)")
            node = self.item("nodes", index)
            world = parent @ _local_matrix(node)
            yield index, world
            stack.extend((child, world) for child in reversed(node.get("children", [])))

    def _primitive(self, primitive: dict, world: np.ndarray, label: str) -> Mesh | None:
        mode = primitive.get("mode", TRIANGLES)
        if mode not in (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN):
            self.fill_ins.note("skipped point and line primitives", f"{label} (mode {mode})")
            return None
        attributes = primitive["attributes"]
        if "POSITION" not in attributes:
            raise UserError(f"{self.path}: primitive {label} has no POSITION attribute")
        positions = self._attribute(attributes, "POSITION", None, 3, label)
        count = len(positions)
        triangles = self._triangles(primitive, mode, count, label)
        if len(triangles) == 0:  # nothing to draw; an empty GPU buffer is an error in some drivers
            return None
        material, uv_set, uv_transform = self._material(primitive.get("material"))
        normals = self._attribute(attributes, "NORMAL", count, 3, label)
        uvs = self._attribute(attributes, f"TEXCOORD_{uv_set}", count, 2, label)

        linear = world[:3, :3]
        positions = positions @ linear.T + world[:3, 3]
        if np.linalg.det(linear) < 0:  # a mirroring transform turns the winding around
            triangles = triangles[:, [0, 2, 1]]
        if normals is None:
            self.fill_ins.note("no normals, computed area-weighted smooth normals", label)
            normals = smooth_normals(positions, triangles)
        else:  # normals transform with the inverse transpose; as row vectors: n @ inv(L)
            normals = normalize_rows(normals @ np.linalg.pinv(linear))
        if uvs is None:
            self.fill_ins.note(f"no TEXCOORD_{uv_set}, texture coordinates filled with (0, 0)", label)
            uvs = np.zeros((count, 2))
        elif uv_transform is not None:
            uvs = uvs @ uv_transform[:2, :2].T + uv_transform[:2, 2]
        return Mesh(positions, normals, uvs, triangles, material, name=label)

    def _attribute(self, attributes: dict, name: str, count: int | None, width: int, label: str):
        """(count, width) float64 values of a vertex attribute, or None when it is absent."""
        if name not in attributes:
            return None
        values = self.accessor(attributes[name])
        if values.shape[1] != width or (count is not None and len(values) != count):
            raise UserError(
                f"{self.path}: attribute {name} of primitive {label} has shape {values.shape}, expected ({count}, {width})"
            )
        return values.astype(np.float64)

    def _triangles(self, primitive: dict, mode: int, count: int, label: str) -> np.ndarray:
        """(T, 3) int64 vertex indices of a triangle list, strip or fan; a non-indexed primitive
        lists its vertices in order."""
        if "indices" in primitive:
            indices = self.accessor(primitive["indices"])
            if indices.shape[1] != 1 or indices.dtype.kind != "u":
                raise UserError(f"{self.path}: indices of primitive {label} are not unsigned integer scalars")
            indices = indices.reshape(-1).astype(np.int64)
        else:
            indices = np.arange(count, dtype=np.int64)
        if indices.size and int(indices.max()) >= count:
            raise UserError(f"{self.path}: primitive {label} has index {int(indices.max())} but only {count} vertices")
        if mode == TRIANGLES:
            if len(indices) % 3:
                raise UserError(f"{self.path}: primitive {label} has {len(indices)} indices, not a multiple of 3")
            return indices.reshape(-1, 3)
        if len(indices) < 3:
            return np.zeros((0, 3), np.int64)
        k = np.arange(len(indices) - 2)
        if mode == TRIANGLE_FAN:
            return np.stack([indices[k + 1], indices[k + 2], np.full_like(k, indices[0])], axis=1)
        odd = k % 2  # every other strip triangle swaps two corners to stay counter-clockwise
        return np.stack([indices[k], indices[k + 1 + odd], indices[k + 2 - odd]], axis=1)

    # --- accessors and buffers ---------------------------------------------------------------

    def accessor(self, index: int) -> np.ndarray:
        """(count, components) array of an accessor: its component dtype, or float32 if normalized."""
        accessor = self.item("accessors", index)
        what = f"accessors[{index}]"
        dtype = COMPONENT_DTYPES.get(accessor["componentType"])
        width = COMPONENT_COUNTS.get(accessor["type"])
        if dtype is None or width is None:
            raise UserError(f"{self.path}: {what} has unknown componentType/type {accessor['componentType']}/{accessor['type']}")
        count = int(accessor["count"])
        if "bufferView" in accessor:
            view, stride = self._buffer_view(accessor["bufferView"])
            values = self._strided(view, accessor.get("byteOffset", 0), count, width, dtype, stride, what)
        else:  # all zeros until sparse values replace some
            values = np.zeros((count, width), dtype)
        if "sparse" in accessor:
            self._apply_sparse(accessor["sparse"], values, what)
        if accessor.get("normalized", False):
            values = _normalized(values)
        return values

    def _apply_sparse(self, sparse: dict, values: np.ndarray, what: str) -> None:
        count = int(sparse["count"])
        spec = sparse["indices"]
        index_dtype = COMPONENT_DTYPES.get(spec["componentType"])
        if index_dtype is None or index_dtype.kind != "u":
            raise UserError(f"{self.path}: {what}: sparse indices must be unsigned integers")
        view, _ = self._buffer_view(spec["bufferView"])
        rows = self._strided(view, spec.get("byteOffset", 0), count, 1, index_dtype, None, what)[:, 0]
        if rows.size and int(rows.max()) >= len(values):
            raise UserError(f"{self.path}: {what}: sparse index {int(rows.max())} is past its {len(values)} elements")
        view, _ = self._buffer_view(sparse["values"]["bufferView"])
        offset = sparse["values"].get("byteOffset", 0)
        values[rows] = self._strided(view, offset, count, values.shape[1], values.dtype, None, what)

    def _strided(self, data, offset: int, count: int, width: int, dtype: np.dtype, stride, what: str) -> np.ndarray:
        element = dtype.itemsize * width
        stride = stride or element
        if stride < element:
            raise UserError(f"{self.path}: {what}: byteStride {stride} is smaller than one element ({element} bytes)")
        end = offset + stride * (count - 1) + element if count else offset
        if offset < 0 or end > len(data):
            raise UserError(f"{self.path}: {what} reads bytes {offset}..{end} of a {len(data)}-byte buffer view")
        if count == 0:
            return np.zeros((0, width), dtype)
        return np.ndarray((count, width), dtype, buffer=data, offset=offset, strides=(stride, dtype.itemsize)).copy()

    def _buffer_view(self, index: int) -> tuple[memoryview, int | None]:
        view = self.item("bufferViews", index)
        buffer = self._buffer(view["buffer"])
        start, length = int(view.get("byteOffset", 0)), int(view["byteLength"])
        if start < 0 or start + length > len(buffer):
            raise UserError(
                f"{self.path}: bufferViews[{index}] (bytes {start}..{start + length}) runs past the end of "
                f"buffers[{view['buffer']}] ({len(buffer)} bytes)"
            )
        return memoryview(buffer)[start : start + length], view.get("byteStride")

    def _buffer(self, index: int) -> bytes:
        if index not in self._buffers:
            spec = self.item("buffers", index)
            if "uri" in spec:
                data = self._read_uri(spec["uri"], f"buffers[{index}]")
                if data is None:
                    raise UserError(f"{self.path}: buffer file '{spec['uri']}' not found")
            elif index == 0 and self.glb_binary is not None:
                data = self.glb_binary
            else:
                raise UserError(f"{self.path}: buffers[{index}] has no uri and there is no .glb binary chunk")
            if len(data) < int(spec["byteLength"]):
                raise UserError(
                    f"{self.path}: buffers[{index}] has {len(data)} bytes but byteLength says {spec['byteLength']} (truncated?)"
                )
            self._buffers[index] = data
        return self._buffers[index]

    def _read_uri(self, uri: str, what: str) -> bytes | None:
        """Bytes of a data URI or of a file next to the glTF; None when the file does not exist."""
        if uri.startswith("data:"):
            header, _, payload = uri.partition(",")
            if not header.endswith(";base64"):
                return urllib.parse.unquote_to_bytes(payload)
            try:
                return base64.b64decode(payload, validate=True)
            except (binascii.Error, ValueError):
                raise UserError(f"{self.path}: {what} has a data URI that is not valid base64") from None
        if "://" in uri:
            raise UserError(f"{self.path}: {what} points to a remote URI ({uri}); only local files are read")
        file = self.path.parent / urllib.parse.unquote(uri)
        return file.read_bytes() if file.is_file() else None

    # --- materials and textures --------------------------------------------------------------

    def _material(self, index: int | None) -> tuple[Material, int, np.ndarray | None]:
        """(material, TEXCOORD set of its base colour texture, (3, 3) UV transform or None)."""
        if index not in self._materials:
            if index is None:  # the glTF default material
                self._materials[None] = (Material(base_color=(1.0, 1.0, 1.0), roughness=1.0, metallic=1.0), 0, None)
            else:
                self._materials[index] = self._read_material(index)
        return self._materials[index]

    def _read_material(self, index: int) -> tuple[Material, int, np.ndarray | None]:
        spec = self.item("materials", index)
        name = spec.get("name") or f"material {index}"
        pbr = spec.get("pbrMetallicRoughness", {})
        factor = [float(c) for c in pbr.get("baseColorFactor", (1.0, 1.0, 1.0, 1.0))]  # linear RGBA
        metallic = float(pbr.get("metallicFactor", 1.0))
        roughness = float(pbr.get("roughnessFactor", 1.0))
        texture, uv_set, uv_transform = None, 0, None
        if "baseColorTexture" in pbr:
            texture = self._texture(pbr["baseColorTexture"])
            uv_set, uv_transform = _texture_coordinates(pbr["baseColorTexture"])
        scalar_note = "texture reduced to its mean (materials hold scalars)"
        if "metallicRoughnessTexture" in pbr:
            image = self._texture(pbr["metallicRoughnessTexture"])
            if image is not None:  # linear data: roughness in green, metallic in blue
                roughness *= float(image[..., 1].mean()) / 255.0
                metallic *= float(image[..., 2].mean()) / 255.0
                self.fill_ins.note(f"metallicRoughness{scalar_note}", name)
        emissive = np.array(spec.get("emissiveFactor", (0.0, 0.0, 0.0)), dtype=np.float64)
        emissive *= float(spec.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0))
        if "emissiveTexture" in spec:
            image = self._texture(spec["emissiveTexture"])
            if image is not None:  # sRGB-encoded colour
                emissive *= srgb_decode(image[..., :3] / 255.0).reshape(-1, 3).mean(axis=0)
                self.fill_ins.note(f"emissive{scalar_note}", name)
        alpha_mode = spec.get("alphaMode", "OPAQUE")
        if alpha_mode not in ALPHA_MODES:
            raise UserError(f"{self.path}: material '{name}' has unknown alphaMode '{alpha_mode}'")
        if alpha_mode != "OPAQUE" and factor[3] < 1.0:
            texture = bake_alpha(texture, factor[3])
        material = Material(
            base_color=(factor[0], factor[1], factor[2]),
            base_color_texture=texture,
            roughness=float(np.clip(roughness, 0.0, 1.0)),
            metallic=float(np.clip(metallic, 0.0, 1.0)),
            emissive=(float(emissive[0]), float(emissive[1]), float(emissive[2])),
            alpha_mode=alpha_mode.lower(),
            alpha_cutoff=float(spec.get("alphaCutoff", 0.5)),
            double_sided=bool(spec.get("doubleSided", False)),
            name=name,
        )
        return material, uv_set, uv_transform

    def _texture(self, texture_info: dict) -> np.ndarray | None:
        """(H, W, 3|4) uint8 image of a textureInfo, or None (with a warning) when unavailable."""
        texture = self.item("textures", texture_info["index"])
        if "source" not in texture:  # e.g. only a KTX2/WebP source inside an extension
            self.fill_ins.note("textures without a PNG/JPEG source ignored", f"textures[{texture_info['index']}]")
            return None
        return self._image(texture["source"])

    def _image(self, index: int) -> np.ndarray | None:
        if index not in self._images:
            spec = self.item("images", index)
            what = f"images[{index}]"
            if "bufferView" in spec:
                view, _ = self._buffer_view(spec["bufferView"])
                data = bytes(view)
            else:
                data = self._read_uri(spec["uri"], what)
            if data is None:
                self.fill_ins.note("texture file not found, used the material's colour factor", spec["uri"])
                self._images[index] = None
            else:
                self._images[index] = decode_image(data, f"{self.path}: {what}")
        return self._images[index]


def _local_matrix(node: dict) -> np.ndarray:
    """(4, 4) float64 local transform of a node: its column-major matrix, or T @ R @ S."""
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    matrix = np.eye(4)
    rotation = _quaternion_matrix(node.get("rotation", (0.0, 0.0, 0.0, 1.0)))
    matrix[:3, :3] = rotation * np.array(node.get("scale", (1.0, 1.0, 1.0)), dtype=np.float64)  # R @ diag(S)
    matrix[:3, 3] = node.get("translation", (0.0, 0.0, 0.0))
    return matrix


def _quaternion_matrix(quaternion) -> np.ndarray:
    """(3, 3) rotation of a unit quaternion given as (x, y, z, w)."""
    x, y, z, w = np.asarray(quaternion, dtype=np.float64) / (np.linalg.norm(quaternion) or 1.0)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _normalized(values: np.ndarray) -> np.ndarray:
    """Integer components mapped to [0, 1] (unsigned) or [-1, 1] (signed), as float32."""
    if values.dtype.kind == "f":
        return values
    scale = float(np.iinfo(values.dtype).max)
    return np.maximum(values.astype(np.float32) / np.float32(scale), np.float32(-1.0))


def _texture_coordinates(texture_info: dict) -> tuple[int, np.ndarray | None]:
    """TEXCOORD set and KHR_texture_transform (3, 3) matrix (offset @ rotation @ scale) of a textureInfo."""
    uv_set = int(texture_info.get("texCoord", 0))
    transform = texture_info.get("extensions", {}).get("KHR_texture_transform")
    if transform is None:
        return uv_set, None
    uv_set = int(transform.get("texCoord", uv_set))
    (offset_u, offset_v), angle = transform.get("offset", (0.0, 0.0)), float(transform.get("rotation", 0.0))
    (scale_u, scale_v) = transform.get("scale", (1.0, 1.0))
    cos, sin = np.cos(angle), np.sin(angle)
    translation = np.array([[1.0, 0.0, offset_u], [0.0, 1.0, offset_v], [0.0, 0.0, 1.0]])
    rotation = np.array([[cos, sin, 0.0], [-sin, cos, 0.0], [0.0, 0.0, 1.0]])
    return uv_set, translation @ rotation @ np.diag([scale_u, scale_v, 1.0])
