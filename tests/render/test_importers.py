"""Scene import: tiny glTF, .glb and OBJ+MTL files built in tmp_path, checked vertex by vertex."""

from __future__ import annotations

import base64
import io
import json
import logging
import struct
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from mnss_kit.errors import UserError
from mnss_kit.render.importers import load_meshes
from mnss_kit.render.importers.common import decode_image, smooth_normals
from mnss_kit.render.importers.obj import roughness_from_shininess

FLOAT, UBYTE, USHORT, UINT, BYTE = 5126, 5121, 5123, 5125, 5120
QUAD = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
QUAD_INDICES = np.array([0, 1, 2, 0, 2, 3], np.uint16)
UP = np.array([0, 0, 1], np.float32)


def png_bytes(pixels: np.ndarray) -> bytes:
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, "PNG")
    return out.getvalue()


CHECKER = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]], np.uint8)


class GltfBuilder:
    """Appends arrays to one binary buffer and writes .gltf (data URI or .bin) or .glb files."""

    def __init__(self):
        self.blob = bytearray()
        self.doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [],
                    "materials": [], "textures": [], "images": [], "accessors": [], "bufferViews": []}  # fmt: skip

    def view(self, data: bytes, stride: int | None = None) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if stride:
            view["byteStride"] = stride
        self.blob += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, array, component_type=FLOAT, **extra) -> int:
        array = np.asarray(array)
        kind = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[1 if array.ndim == 1 else array.shape[1]]
        accessor = {"bufferView": self.view(array.tobytes()), "componentType": component_type, "count": len(array), "type": kind}
        self.doc["accessors"].append({**accessor, **extra})
        return len(self.doc["accessors"]) - 1

    def mesh(self, positions=QUAD, indices=QUAD_INDICES, normals=True, node: dict | None = None, **primitive) -> int:
        attributes = {"POSITION": self.accessor(positions)}
        if normals is True:
            normals = np.tile(UP, (len(positions), 1))
        if normals is not False:
            attributes["NORMAL"] = self.accessor(np.asarray(normals, np.float32))
        primitive = {"attributes": attributes, **primitive}
        if indices is not None:
            primitive["indices"] = self.accessor(indices, USHORT)
        self.doc["meshes"].append({"primitives": [primitive]})
        return self.node({"mesh": len(self.doc["meshes"]) - 1, **(node or {})})

    def node(self, node: dict, root: bool = True) -> int:
        self.doc["nodes"].append(node)
        index = len(self.doc["nodes"]) - 1
        if root:
            self.doc["scenes"][0]["nodes"].append(index)
        return index

    def material(self, **spec) -> int:
        self.doc["materials"].append(spec)
        return len(self.doc["materials"]) - 1

    def texture(self, image: dict) -> int:
        self.doc["images"].append(image)
        self.doc["textures"].append({"source": len(self.doc["images"]) - 1})
        return len(self.doc["textures"]) - 1

    def write_gltf(self, path, external_bin: str | None = None):
        buffer = {"byteLength": len(self.blob)}
        if external_bin:
            (path.parent / external_bin).write_bytes(bytes(self.blob))
            buffer["uri"] = external_bin.replace(" ", "%20")
        else:
            buffer["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.blob)).decode()
        path.write_text(json.dumps({**self.doc, "buffers": [buffer]}))
        return path

    def write_glb(self, path):
        text = json.dumps({**self.doc, "buffers": [{"byteLength": len(self.blob)}]}).encode()
        text += b" " * (-len(text) % 4)
        binary = bytes(self.blob) + b"\0" * (-len(self.blob) % 4)
        chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
        path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)
        return path


def warnings_from(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING and r.name.startswith("mnss_kit")]


def face_normals(mesh) -> np.ndarray:
    p = mesh.positions[mesh.indices]
    return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])


# --- glTF geometry -----------------------------------------------------------------------------


def test_gltf_node_hierarchy_matrix_and_trs_baked_into_world_space(tmp_path):
    gltf = GltfBuilder()
    gltf.mesh(node={"name": "not in the default scene"})
    gltf.doc["scenes"] = [{"nodes": [0]}, {"nodes": []}]
    gltf.doc["scene"] = 1
    child = gltf.mesh(node={"rotation": [0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)], "scale": [2, 2, 2], "translation": [0, 0, 1]})
    gltf.doc["scenes"][1]["nodes"] = [gltf.node({"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 10, 0, 0, 1], "children": [child]}, root=False)]
    meshes = load_meshes(gltf.write_gltf(tmp_path / "scene.gltf"))
    assert len(meshes) == 1
    # child: scale 2, then 90 degrees about +z, then +1 in z; parent: +10 in x
    np.testing.assert_allclose(meshes[0].positions, [[10, 0, 1], [10, 2, 1], [8, 2, 1], [8, 0, 1]], atol=1e-5)
    np.testing.assert_allclose(meshes[0].normals, np.tile(UP, (4, 1)), atol=1e-6)
    np.testing.assert_array_equal(meshes[0].indices, QUAD_INDICES.reshape(-1, 3))
    assert meshes[0].indices.dtype == np.uint32 and meshes[0].positions.dtype == np.float32


def test_gltf_mirroring_transform_keeps_front_faces_counter_clockwise(tmp_path):
    gltf = GltfBuilder()
    gltf.mesh(node={"scale": [-1, 1, 1]})
    (mesh,) = load_meshes(gltf.write_gltf(tmp_path / "mirror.gltf"))
    np.testing.assert_allclose(mesh.positions[:, 0], -QUAD[:, 0])
    assert (face_normals(mesh) @ UP > 0).all()  # winding still agrees with the +z normals


def test_gltf_normals_transform_with_the_inverse_transpose(tmp_path):
    gltf = GltfBuilder()
    slanted = np.tile(np.array([1, 1, 0], np.float32) / np.sqrt(2), (4, 1))
    gltf.mesh(normals=slanted, node={"scale": [2, 1, 1]})
    gltf.mesh(node={"rotation": [np.sin(np.pi / 4), 0, 0, np.cos(np.pi / 4)]})  # +90 degrees about +x
    stretched, rotated = load_meshes(gltf.write_gltf(tmp_path / "normals.gltf"))
    np.testing.assert_allclose(stretched.normals, np.tile([0.5, 1, 0] / np.hypot(0.5, 1), (4, 1)), atol=1e-6)
    np.testing.assert_allclose(rotated.normals, np.tile([0, -1, 0], (4, 1)), atol=1e-6)


def test_gltf_missing_normals_and_uvs_filled_with_one_warning_each(tmp_path, caplog):
    gltf = GltfBuilder()
    gltf.mesh(normals=False)
    gltf.mesh(normals=False, node={"translation": [0, 0, 5]})
    path = gltf.write_gltf(tmp_path / "bare.gltf")
    with caplog.at_level(logging.WARNING):
        meshes = load_meshes(path)
    for mesh in meshes:
        np.testing.assert_allclose(mesh.normals, np.tile(UP, (4, 1)), atol=1e-6)
        np.testing.assert_array_equal(mesh.uvs, np.zeros((4, 2)))
    messages = warnings_from(caplog)
    assert len(messages) == 2, messages
    assert all(str(path) in m for m in messages)
    assert any("normals" in m for m in messages) and any("(0, 0)" in m for m in messages)


def test_smooth_normals_are_area_weighted_and_welded_across_seams():
    # vertex 0 is shared by a big triangle in the xy plane (+z) and a small one in the yz plane (+x);
    # vertex 5 duplicates vertex 0's position (a UV seam) and must get the same normal
    positions = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 1], [0, 1, 0], [0, 0, 0]], np.float32)
    normals = smooth_normals(positions, np.array([[0, 1, 2], [5, 4, 3]]))
    expected = np.array([0.5, 0, 2.0]) / np.hypot(0.5, 2.0)  # twice the areas: 0.5 (+x) and 2 (+z)
    np.testing.assert_allclose(normals[0], expected, atol=1e-6)
    np.testing.assert_allclose(normals[5], expected, atol=1e-6)
    np.testing.assert_allclose(normals[1], [0, 0, 1], atol=1e-6)


@pytest.mark.parametrize("index_type, dtype", [(UBYTE, np.uint8), (USHORT, np.uint16), (UINT, np.uint32)])
def test_gltf_accessors_interleaved_normalized_sparse(tmp_path, index_type, dtype):
    gltf = GltfBuilder()
    uv_u16 = np.array([[0, 0], [65535, 0], [65535, 32768], [0, 65535]], np.uint16)
    normal_i8 = np.array([[0, 0, 127, 0]] * 4, np.int8)  # padded to 4 bytes per element
    record = np.zeros(4, dtype=[("position", "<f4", 3), ("uv", "<u2", 2), ("normal", "i1", 4)])
    record["position"], record["uv"], record["normal"] = QUAD, uv_u16, normal_i8
    view = gltf.view(record.tobytes(), stride=record.itemsize)
    gltf.doc["accessors"] += [
        {"bufferView": view, "byteOffset": 0, "componentType": FLOAT, "count": 4, "type": "VEC3",
         "sparse": {"count": 1, "indices": {"bufferView": gltf.view(np.array([2], np.uint8).tobytes()), "componentType": UBYTE},
                    "values": {"bufferView": gltf.view(np.array([5, 5, 5], np.float32).tobytes())}}},
        {"bufferView": view, "byteOffset": 12, "componentType": USHORT, "normalized": True, "count": 4, "type": "VEC2"},
        {"bufferView": view, "byteOffset": 16, "componentType": BYTE, "normalized": True, "count": 4, "type": "VEC3"},
    ]  # fmt: skip
    indices = gltf.accessor(np.array([0, 1, 2, 0, 2, 3], dtype), index_type)
    gltf.doc["meshes"].append({"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "NORMAL": 2}, "indices": indices}]})
    gltf.node({"mesh": 0})
    (mesh,) = load_meshes(gltf.write_gltf(tmp_path / "packed.gltf"))
    np.testing.assert_allclose(mesh.positions, [[0, 0, 0], [1, 0, 0], [5, 5, 5], [0, 1, 0]])
    np.testing.assert_allclose(mesh.uvs, uv_u16 / 65535.0, atol=1e-6)
    np.testing.assert_allclose(mesh.normals, np.tile(UP, (4, 1)), atol=1e-6)
    np.testing.assert_array_equal(mesh.indices, [[0, 1, 2], [0, 2, 3]])


def test_gltf_non_indexed_primitive_gets_sequential_triangles(tmp_path):
    gltf = GltfBuilder()
    gltf.mesh(positions=QUAD[[0, 1, 2, 0, 2, 3]], indices=None)
    (mesh,) = load_meshes(gltf.write_gltf(tmp_path / "soup.gltf"))
    np.testing.assert_array_equal(mesh.indices, [[0, 1, 2], [3, 4, 5]])


@pytest.mark.parametrize("mode, indices", [(5, [0, 1, 3, 2]), (6, [0, 1, 2, 3])])  # strip, fan
def test_gltf_triangle_strips_and_fans_become_counter_clockwise_lists(tmp_path, mode, indices):
    gltf = GltfBuilder()
    gltf.mesh(indices=np.array(indices, np.uint16), mode=mode)
    (mesh,) = load_meshes(gltf.write_gltf(tmp_path / "strip.gltf"))
    assert len(mesh.indices) == 2 and len({tuple(sorted(t)) for t in mesh.indices.tolist()}) == 2
    assert (face_normals(mesh) @ UP > 0).all()


def test_gltf_non_triangle_primitives_are_skipped_with_a_warning(tmp_path, caplog):
    gltf = GltfBuilder()
    gltf.mesh()
    gltf.mesh(mode=1)  # LINES
    gltf.mesh(indices=np.zeros(0, np.uint16))  # empty: dropped without a warning
    with caplog.at_level(logging.WARNING):
        meshes = load_meshes(gltf.write_gltf(tmp_path / "lines.gltf"))
    assert len(meshes) == 1
    assert [m for m in warnings_from(caplog) if "mode" in m] == [f"{tmp_path / 'lines.gltf'}: skipped point and line primitives: node 1/0 (mode 1)"]
    only_lines = GltfBuilder()
    only_lines.mesh(mode=1)
    with pytest.raises(UserError, match="no triangle geometry"):
        load_meshes(only_lines.write_gltf(tmp_path / "only_lines.gltf"))


# --- glTF materials ----------------------------------------------------------------------------


def test_glb_with_texture_in_buffer_view_and_material_factors(tmp_path):
    gltf = GltfBuilder()
    image = gltf.view(png_bytes(CHECKER))
    texture = gltf.texture({"bufferView": image, "mimeType": "image/png"})
    material = gltf.material(
        name="painted",
        pbrMetallicRoughness={"baseColorFactor": [0.5, 0.25, 1.0, 1.0], "baseColorTexture": {"index": texture},
                              "metallicFactor": 0.3, "roughnessFactor": 0.7},
        emissiveFactor=[1.0, 0.5, 0.0], alphaMode="MASK", alphaCutoff=0.25, doubleSided=True,
    )  # fmt: skip
    gltf.mesh(material=material)
    (mesh,) = load_meshes(gltf.write_glb(tmp_path / "scene.glb"))
    m = mesh.material
    np.testing.assert_array_equal(m.base_color_texture, CHECKER)
    assert m.base_color == (0.5, 0.25, 1.0) and m.emissive == (1.0, 0.5, 0.0)
    assert (m.metallic, m.roughness) == pytest.approx((0.3, 0.7))
    assert (m.alpha_mode, m.alpha_cutoff, m.double_sided, m.name) == ("mask", 0.25, True, "painted")


def test_exporter_style_glb_with_several_meshes_materials_and_textures(tmp_path, caplog):
    # What a game-level export looks like (no such file ships in a small registry package): one
    # buffer shared by every mesh, a mesh of two primitives with different materials, two textures
    # embedded as buffer views and shared between materials, a node hierarchy, a mesh without
    # normals, and loose edges exported as a LINES primitive.
    gltf = GltfBuilder()
    bricks, moss = (gltf.texture({"bufferView": gltf.view(png_bytes(image)), "mimeType": "image/png"})
                    for image in (CHECKER, CHECKER[::-1].copy()))
    wall, floor, trim = (gltf.material(name=name, pbrMetallicRoughness={"baseColorTexture": {"index": t}})
                         for name, t in (("wall", bricks), ("floor", moss), ("trim", bricks)))
    uvs = gltf.accessor(QUAD[:, :2].copy())
    house = gltf.mesh(material=wall, node={"translation": [10, 0, 0]})
    second = {"attributes": {"POSITION": gltf.accessor(QUAD + [0, 0, 1]), "TEXCOORD_0": uvs},
              "indices": gltf.accessor(QUAD_INDICES, USHORT), "material": trim}  # fmt: skip
    gltf.doc["meshes"][-1]["primitives"].append(second)
    gltf.doc["meshes"][-1]["primitives"][0]["attributes"]["TEXCOORD_0"] = uvs
    ground = gltf.mesh(material=floor, normals=False, node={"scale": [50, 50, 1]})
    gltf.doc["nodes"][house]["children"] = [ground]
    gltf.doc["scenes"][0]["nodes"].remove(ground)  # the ground hangs below the house node
    gltf.mesh(mode=1, normals=False)  # loose edges
    with caplog.at_level(logging.WARNING):
        meshes = load_meshes(gltf.write_glb(tmp_path / "level.glb"))
    assert [m.material.name for m in meshes] == ["wall", "trim", "floor"]
    assert meshes[0].material.base_color_texture is meshes[1].material.base_color_texture  # one decode per image
    np.testing.assert_array_equal(meshes[2].material.base_color_texture, CHECKER[::-1])
    np.testing.assert_allclose(meshes[2].positions, QUAD * [50, 50, 1] + [10, 0, 0])  # parent transform baked
    np.testing.assert_allclose(meshes[2].normals, np.tile(UP, (4, 1)), atol=1e-6)  # computed for the ground
    messages = warnings_from(caplog)
    assert len([m for m in messages if "mode 1" in m]) == 1 and all("level.glb" in m for m in messages)


def test_gltf_default_material_follows_the_specification(tmp_path):
    gltf = GltfBuilder()
    gltf.mesh()
    (mesh,) = load_meshes(gltf.write_gltf(tmp_path / "plain.gltf"))
    assert mesh.material.base_color == (1.0, 1.0, 1.0)
    assert (mesh.material.metallic, mesh.material.roughness, mesh.material.alpha_mode) == (1.0, 1.0, "opaque")


def test_gltf_external_buffer_and_image_files(tmp_path):
    gltf = GltfBuilder()
    (tmp_path / "wood grain.png").write_bytes(png_bytes(CHECKER))
    texture = gltf.texture({"uri": "wood%20grain.png"})
    gltf.mesh(material=gltf.material(pbrMetallicRoughness={"baseColorTexture": {"index": texture}}))
    (mesh,) = load_meshes(gltf.write_gltf(tmp_path / "scene.gltf", external_bin="scene data.bin"))
    np.testing.assert_array_equal(mesh.material.base_color_texture, CHECKER)
    np.testing.assert_allclose(mesh.positions, QUAD)


def test_gltf_data_uri_image_and_texture_transform(tmp_path):
    gltf = GltfBuilder()
    texture = gltf.texture({"uri": "data:image/png;base64," + base64.b64encode(png_bytes(CHECKER)).decode()})
    transform = {"KHR_texture_transform": {"offset": [0.5, 0.0], "scale": [2.0, 2.0]}}
    material = gltf.material(pbrMetallicRoughness={"baseColorTexture": {"index": texture, "extensions": transform}})
    node = gltf.mesh(material=material)
    uvs = gltf.accessor(np.array([[0.25, 0.25]] * 4, np.float32))
    gltf.doc["meshes"][gltf.doc["nodes"][node]["mesh"]]["primitives"][0]["attributes"]["TEXCOORD_0"] = uvs
    (mesh,) = load_meshes(gltf.write_gltf(tmp_path / "transformed.gltf"))
    np.testing.assert_array_equal(mesh.material.base_color_texture, CHECKER)
    np.testing.assert_allclose(mesh.uvs, [[1.0, 0.5]] * 4)


def test_gltf_missing_texture_file_keeps_colour_factor_and_warns_once(tmp_path, caplog):
    gltf = GltfBuilder()
    texture = gltf.texture({"uri": "lost.png"})
    factor = {"baseColorFactor": [0.2, 0.4, 0.6, 1.0], "baseColorTexture": {"index": texture}}
    gltf.mesh(material=gltf.material(pbrMetallicRoughness=factor))
    gltf.mesh(material=gltf.material(pbrMetallicRoughness=factor))
    with caplog.at_level(logging.WARNING):
        meshes = load_meshes(gltf.write_gltf(tmp_path / "scene.gltf"))
    assert all(m.material.base_color_texture is None and m.material.base_color == (0.2, 0.4, 0.6) for m in meshes)
    texture_warnings = [m for m in warnings_from(caplog) if "lost.png" in m]
    assert len(texture_warnings) == 1 and "scene.gltf" in texture_warnings[0]


def test_gltf_metallic_roughness_texture_becomes_its_mean_with_one_warning(tmp_path, caplog):
    gltf = GltfBuilder()
    pixels = np.zeros((2, 2, 3), np.uint8)
    pixels[..., 1] = [[255, 255], [0, 0]]  # roughness mean 0.5
    pixels[..., 2] = [[255, 0], [0, 0]]  # metallic mean 0.25
    texture = gltf.texture({"uri": "data:image/png;base64," + base64.b64encode(png_bytes(pixels)).decode()})
    for name in ("first", "second"):
        mr = {"metallicRoughnessTexture": {"index": texture}, "metallicFactor": 1.0, "roughnessFactor": 0.8}
        gltf.mesh(material=gltf.material(name=name, pbrMetallicRoughness=mr))
    with caplog.at_level(logging.WARNING):
        meshes = load_meshes(gltf.write_gltf(tmp_path / "mr.gltf"))
    for mesh in meshes:
        assert (mesh.material.metallic, mesh.material.roughness) == pytest.approx((0.25, 0.4))
    mean_warnings = [m for m in warnings_from(caplog) if "metallicRoughness" in m]
    assert len(mean_warnings) == 1 and "first" in mean_warnings[0] and "second" in mean_warnings[0]


def test_gltf_blend_alpha_factor_is_carried_by_the_texture(tmp_path):
    gltf = GltfBuilder()
    pbr = {"baseColorFactor": [1.0, 0.0, 0.0, 0.5]}
    gltf.mesh(material=gltf.material(pbrMetallicRoughness=pbr, alphaMode="BLEND"))
    (mesh,) = load_meshes(gltf.write_gltf(tmp_path / "glass.gltf"))
    assert mesh.material.alpha_mode == "blend" and mesh.material.base_color == (1.0, 0.0, 0.0)
    np.testing.assert_array_equal(mesh.material.base_color_texture, [[[255, 255, 255, 128]]])


def test_decode_image_scales_16_bit_grey_and_keeps_palette_transparency():
    grey16 = np.array([[0, 20000], [40000, 65535]], np.uint16)
    decoded = decode_image(png_bytes(grey16), "grey16.png")
    np.testing.assert_array_equal(decoded, np.repeat(np.round(grey16 / 257.0)[..., None], 3, axis=2))
    palette = Image.new("P", (2, 2))
    palette.info["transparency"] = 0
    out = io.BytesIO()
    palette.save(out, "PNG")
    assert decode_image(out.getvalue(), "palette.png").shape == (2, 2, 4)


# --- bad glTF input ----------------------------------------------------------------------------


def _valid(tmp_path):
    gltf = GltfBuilder()
    gltf.mesh()
    return gltf


def _edit(tmp_path, change, name="bad.gltf"):
    gltf = _valid(tmp_path)
    change(gltf.doc)
    return gltf.write_gltf(tmp_path / name)


def _truncated_glb(tmp_path):
    path = _valid(tmp_path).write_glb(tmp_path / "cut.glb")
    path.write_bytes(path.read_bytes()[:60])
    return path


def _missing_bin(tmp_path):
    path = _valid(tmp_path).write_gltf(tmp_path / "external.gltf", external_bin="external.bin")
    (tmp_path / "external.bin").unlink()
    return path


def _corrupt_image(tmp_path):
    gltf = _valid(tmp_path)
    gltf.doc["meshes"][0]["primitives"][0]["material"] = gltf.material(
        pbrMetallicRoughness={"baseColorTexture": {"index": gltf.texture({"uri": "data:image/png;base64,AAAA"})}}
    )
    return gltf.write_gltf(tmp_path / "corrupt.gltf")


def _file(directory, name, content):
    path = directory / name
    path.write_bytes(content.encode() if isinstance(content, str) else content)
    return path


BAD_GLTF = {
    "not found": (lambda d: d / "missing.gltf", "not found"),
    "unsupported extension": (lambda d: _file(d, "scene.fbx", "x"), "unsupported scene file type"),
    "invalid json": (lambda d: _file(d, "broken.gltf", "{not json"), "invalid JSON"),
    "truncated glb": (_truncated_glb, "truncated"),
    "tiny glb": (lambda d: _file(d, "tiny.glb", b"glTF\x02"), "truncated"),
    "glb bad magic": (lambda d: _file(d, "magic.glb", b"NOPE" + bytes(20)), "not a binary glTF"),
    "gltf 1.0": (lambda d: _edit(d, lambda doc: doc["asset"].update(version="1.0")), "unsupported glTF version"),
    "no asset": (lambda d: _edit(d, lambda doc: doc.pop("asset")), "unsupported glTF version"),
    "accessor index out of range": (
        lambda d: _edit(d, lambda doc: doc["meshes"][0]["primitives"][0]["attributes"].update(POSITION=42)), r"accessors\[42\]"),
    "accessor past view end": (lambda d: _edit(d, lambda doc: doc["accessors"][0].update(count=400)), "reads bytes"),
    "view past buffer end": (lambda d: _edit(d, lambda doc: doc["bufferViews"][0].update(byteOffset=10**6)), "past the end"),
    "vertex index out of range": (lambda d: _edit(d, lambda doc: doc["accessors"][0].update(count=2)), "index 3 but only 2"),
    "missing buffer file": (_missing_bin, "not found"),
    "required extension": (lambda d: _edit(d, lambda doc: doc.update(extensionsRequired=["KHR_draco_mesh_compression"])),
                           "KHR_draco_mesh_compression"),
    "no position": (lambda d: _edit(d, lambda doc: doc["meshes"][0]["primitives"][0]["attributes"].pop("POSITION")), "POSITION"),
    "missing property": (lambda d: _edit(d, lambda doc: doc["accessors"][0].pop("count")), "count"),
    "corrupt image": (_corrupt_image, "cannot decode image"),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD_GLTF))
def test_bad_input_raises_a_one_line_user_error_naming_the_file(tmp_path, case):
    make, pattern = BAD_GLTF[case]
    path = make(tmp_path)
    with pytest.raises(UserError, match=pattern) as raised:
        load_meshes(path)
    message = str(raised.value)
    assert path.name in message and "\n" not in message


# --- OBJ + MTL ---------------------------------------------------------------------------------

CUBE_CORNERS = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
# each face: corner numbers (1-based) counter-clockwise seen from outside, and its outward normal
CUBE_FACES = [((1, 4, 3, 2), (0, 0, -1)), ((5, 6, 7, 8), (0, 0, 1)), ((1, 2, 6, 5), (0, -1, 0)),
              ((3, 4, 8, 7), (0, 1, 0)), ((1, 5, 8, 4), (-1, 0, 0)), ((2, 3, 7, 6), (1, 0, 0))]  # fmt: skip
FACE_UVS = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]  # OBJ convention: v grows upwards


def test_obj_quads_negative_indices_and_missing_vt_vn(tmp_path, caplog):
    lines = [f"v {x} {y} {z}" for x, y, z in CUBE_CORNERS]
    lines += ["f " + " ".join(str(c - 9) for c in corners) for corners, _ in CUBE_FACES]  # -8 is corner 1
    path = tmp_path / "cube.obj"
    path.write_text("\n".join(lines) + "\n")
    with caplog.at_level(logging.WARNING):
        (mesh,) = load_meshes(path)
    assert len(mesh.indices) == 12 and len(mesh.positions) == 8
    centre = np.full(3, 0.5)
    outward = (mesh.positions - centre) / np.linalg.norm(mesh.positions - centre, axis=1, keepdims=True)
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-6)
    assert (np.einsum("ij,ij->i", mesh.normals, outward) > 0.9).all()  # smooth: between the 3 face normals
    face_centres = mesh.positions[mesh.indices].mean(axis=1) - centre
    assert (np.einsum("ij,ij->i", face_normals(mesh), face_centres) > 0).all()  # fans keep the winding
    np.testing.assert_array_equal(mesh.uvs, 0)
    messages = warnings_from(caplog)
    assert len(messages) == 2 and all("cube.obj" in m for m in messages)


def test_obj_loose_edges_lines_and_points_are_skipped_with_one_counting_warning(tmp_path, caplog):
    # Blender writes loose edges as two-corner faces at the end of the file (samurai_monastry.obj has 201)
    lines = [f"v {x} {y} {z}" for x, y, z in CUBE_CORNERS]
    lines += ["f " + " ".join(map(str, corners)) for corners, _ in CUBE_FACES]
    lines += ["f 1 7", "f 2 8", "f 3", "l 1 2 3", "p 4"]
    path = tmp_path / "loose.obj"
    path.write_text("\n".join(lines) + "\n")
    with caplog.at_level(logging.WARNING):
        (mesh,) = load_meshes(path)
    assert len(mesh.indices) == 12
    skipped = [m for m in warnings_from(caplog) if "skipped" in m]
    assert skipped == [f"{path}: skipped 3 face(s) of fewer than 3 corners, 1 line(s), 1 point(s): no surface to render"]


# Real exported OBJ files from a package the registries serve (airo-models, MIT, in the test extra):
# CAD/Blender exports of robot arms and grippers with loose edges (`l`), several materials, no normals.
REAL_OBJ_FILES = {
    "arms/ur5e/visual/wrist1.obj": {"lines": 7, "materials": 3},
    "grippers/robotiq_2f_85/meshes/visual/robotiq_arg2f_85_outer_knuckle.obj": {"lines": 0, "materials": 1},
    "arms/ur3e/visual/base_cable_labels.obj": {"lines": 0, "materials": 4},
}


@pytest.mark.parametrize("relative", sorted(REAL_OBJ_FILES))
def test_real_exported_obj_files_import(relative, caplog):
    import airo_models  # in the test extra, so the test runs wherever the tests do
    path = Path(airo_models.__file__).parent / relative
    text = path.read_text()
    expected = REAL_OBJ_FILES[relative]
    with caplog.at_level(logging.WARNING):
        meshes = load_meshes(path)
    assert len(meshes) == expected["materials"]
    faces = sum(len(line.split()) - 3 for line in text.splitlines() if line.startswith("f "))  # a fan: corners - 2
    assert sum(len(m.indices) for m in meshes) == faces
    for mesh in meshes:
        assert np.isfinite(mesh.positions).all() and mesh.indices.max() < len(mesh.positions)
        np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-5)
    skipped = [m for m in warnings_from(caplog) if "skipped" in m]
    assert skipped == ([f"{path}: skipped {expected['lines']} line(s): no surface to render"] if expected["lines"] else [])
    if "vn " not in text:
        assert any("no vn" in m for m in warnings_from(caplog))


def test_obj_mtl_materials_textures_and_v_flip(tmp_path):
    Image.fromarray(CHECKER).save(tmp_path / "bricks.png")
    (tmp_path / "scene.mtl").write_text(
        "newmtl bricks\nKd 0.2 0.3 0.4\nNs 250\nmap_Kd -s 1 1 1 -clamp on bricks.png\n"
        "newmtl lamp\nKd 0.5\nKe 2 1 0\nNs 1000\nd 0.5\n"
        "newmtl pbr\nKd 0.1 0.1 0.1\nNs 0\nPr 0.25\nPm 1\nTr 0\n"
    )
    (tmp_path / "scene.obj").write_text(
        "mtllib scene.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0.25 0.75\nvn 0 0 2\n"
        "usemtl bricks\nf 1/1/1 2/1/1 3/1/1\nusemtl lamp\nf 1//1 2//1 3//1\nusemtl pbr\nf -3//-1 -2//-1 -1//-1\n"
    )
    bricks, lamp, pbr = load_meshes(tmp_path / "scene.obj")
    assert (bricks.name, lamp.name, pbr.name) == ("bricks", "lamp", "pbr")
    np.testing.assert_allclose(bricks.uvs, [[0.25, 0.25]] * 3)  # v flipped
    np.testing.assert_allclose(bricks.normals, [[0, 0, 1]] * 3)  # vn normalised
    np.testing.assert_array_equal(bricks.material.base_color_texture, CHECKER)
    assert bricks.material.base_color == (1.0, 1.0, 1.0)  # a loaded map_Kd replaces Kd
    assert bricks.material.roughness == pytest.approx(0.5) and bricks.material.alpha_mode == "opaque"
    assert lamp.material.base_color == (0.5, 0.5, 0.5) and lamp.material.emissive == (2.0, 1.0, 0.0)
    assert lamp.material.roughness == pytest.approx(0.0) and lamp.material.alpha_mode == "blend"
    np.testing.assert_array_equal(lamp.material.base_color_texture, [[[255, 255, 255, 128]]])
    assert (pbr.material.roughness, pbr.material.metallic, pbr.material.alpha_mode) == (0.25, 1.0, "opaque")


def test_obj_shininess_mapping_inverts_blenders_export():
    for roughness in (0.0, 0.3, 0.5, 1.0):
        assert roughness_from_shininess(1000 * (1 - roughness) ** 2) == pytest.approx(roughness)
    assert roughness_from_shininess(5000) == 0.0 and roughness_from_shininess(-1) == 1.0


def test_obj_map_d_gives_an_alpha_tested_material(tmp_path):
    Image.fromarray(CHECKER).save(tmp_path / "leaf.png")
    Image.fromarray(np.array([[0, 255], [255, 0]], np.uint8)).save(tmp_path / "leaf_mask.png")
    (tmp_path / "leaf.mtl").write_text("newmtl leaf\nmap_Kd leaf.png\nmap_d leaf_mask.png\n")
    (tmp_path / "leaf.obj").write_text("mtllib leaf.mtl\nusemtl leaf\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (mesh,) = load_meshes(tmp_path / "leaf.obj")
    assert mesh.material.alpha_mode == "mask"
    np.testing.assert_array_equal(mesh.material.base_color_texture[..., :3], CHECKER)
    np.testing.assert_array_equal(mesh.material.base_color_texture[..., 3], [[0, 255], [255, 0]])


def test_obj_missing_library_texture_and_material_fall_back_with_warnings(tmp_path, caplog):
    (tmp_path / "a.mtl").write_text("newmtl painted\nKd 0.1 0.2 0.3\nmap_Kd gone.png\n")
    (tmp_path / "scene.obj").write_text(
        "mtllib a.mtl nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
        "usemtl painted\nf 1/1/1 2/1/1 3/1/1\nusemtl unknown\nf 1/1/1 2/1/1 3/1/1\n"
    )
    with caplog.at_level(logging.WARNING):
        painted, unknown = load_meshes(tmp_path / "scene.obj")
    assert painted.material.base_color == (0.1, 0.2, 0.3) and painted.material.base_color_texture is None
    assert unknown.material.base_color == (0.8, 0.8, 0.8)
    messages = warnings_from(caplog)
    assert len(messages) == 3 and all("scene.obj" in m for m in messages)
    for expected in ("gone.png", "nowhere.mtl", "unknown"):
        assert sum(expected in m for m in messages) == 1


@pytest.mark.parametrize(
    "body, pattern",
    [
        ("v 0 0 0\nv 1 0 0\nf 1 2 3\n", r"bad\.obj:3: vertex index 3 is out of range"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "vertex index 0"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n", "vertex index -4"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", "texture index 1"),
        ("v 0 zero 0\n", r"bad\.obj:1: 'v' expects numbers"),
        ("v 0 0\n", "at least 3 numbers"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "not a vertex index"),
        ("# nothing but a comment\n", "no triangle geometry"),
    ],
)
def test_obj_bad_input_raises_user_error_with_line(tmp_path, body, pattern):
    (tmp_path / "bad.obj").write_text(body)
    with pytest.raises(UserError, match=pattern):
        load_meshes(tmp_path / "bad.obj")


# --- the same scene from both formats ----------------------------------------------------------


def _canonical_triangles(meshes) -> np.ndarray:
    """Every triangle as (3 corners x (position, normal, uv)), rotated to start at its smallest corner
    (so the winding is kept) and sorted, rounded to 1e-5."""
    triangles = []
    for mesh in meshes:
        corners = np.concatenate([mesh.positions, mesh.normals, mesh.uvs], axis=1).round(5)[mesh.indices]
        for corner in corners:
            start = min(range(3), key=lambda k: tuple(corner[k]))
            triangles.append(np.roll(corner, -start, axis=0).reshape(-1))
    return np.array(sorted(triangles, key=tuple))


def test_gltf_and_equivalent_obj_give_the_same_triangles(tmp_path):
    lines = ["mtllib cube.mtl"] + [f"v {x} {y} {z}" for x, y, z in CUBE_CORNERS]
    lines += [f"vt {u} {v}" for u, v in FACE_UVS] + [f"vn {x} {y} {z}" for _, (x, y, z) in CUBE_FACES]
    lines.append("usemtl red")
    for face, (corners, _) in enumerate(CUBE_FACES):
        lines.append("f " + " ".join(f"{c}/{k + 1}/{face + 1}" for k, c in enumerate(corners)))
    (tmp_path / "cube.obj").write_text("\n".join(lines) + "\n")
    (tmp_path / "cube.mtl").write_text("newmtl red\nKd 1 0 0\n")

    positions, normals, uvs, indices = [], [], [], []
    for corners, normal in CUBE_FACES:
        base = len(positions)
        positions += [CUBE_CORNERS[c - 1] for c in corners]
        normals += [normal] * 4
        uvs += [(u, 1.0 - v) for u, v in FACE_UVS]  # glTF: v grows downwards
        indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    gltf = GltfBuilder()
    attributes = {"POSITION": gltf.accessor(np.array(positions, np.float32)), "NORMAL": gltf.accessor(np.array(normals, np.float32)),
                  "TEXCOORD_0": gltf.accessor(np.array(uvs, np.float32))}  # fmt: skip
    red = gltf.material(name="red", pbrMetallicRoughness={"baseColorFactor": [1, 0, 0, 1]})
    primitive = {"attributes": attributes, "indices": gltf.accessor(np.array(indices, np.uint16), USHORT), "material": red}
    gltf.doc["meshes"].append({"primitives": [primitive]})
    gltf.node({"mesh": 0})

    from_obj = load_meshes(tmp_path / "cube.obj")
    from_gltf = load_meshes(gltf.write_gltf(tmp_path / "cube.gltf"))
    assert len(_canonical_triangles(from_obj)) == 12
    np.testing.assert_allclose(_canonical_triangles(from_obj), _canonical_triangles(from_gltf), atol=1e-6)
    assert from_obj[0].material.base_color == from_gltf[0].material.base_color == (1.0, 0.0, 0.0)
