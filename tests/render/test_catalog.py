"""The furniture catalogue (render/catalog.py) and the rooms scenes built from it: splits that share
no mesh or texture, props sized as the catalogue says, a camera that passes through doorways."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from mnss_kit.errors import UserError
from mnss_kit.render import catalog
from mnss_kit.render.scenes import rooms

CUBE_OBJ = """mtllib {name}.mtl
v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nv 0 0 4\nv 2 0 4\nv 2 1 4\nv 0 1 4
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1
usemtl skin
f 1/1 2/2 3/3 4/4\nf 5/1 8/4 7/3 6/2\nf 1/1 5/2 6/3 2/4\nf 4/1 3/2 7/3 8/4\nf 1/1 4/2 8/3 5/4\nf 2/1 6/2 7/3 3/4
"""


def _png(seed: int) -> bytes:
    import io

    from PIL import Image

    pixels = np.random.default_rng(seed).integers(0, 255, (256, 256, 3), dtype=np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(pixels).save(buffer, format="PNG")
    return buffer.getvalue()


def write_catalog(path, count: int = 24, shared_texture: bool = True):
    """A .sh3f like Sweet Home 3D's: one folder per model (OBJ, MTL, texture) and the properties."""
    lines = []
    with zipfile.ZipFile(path, "w") as archive:
        for k in range(count):
            name = f"prop{k}"
            archive.writestr(f"cat/{name}/{name}.obj", CUBE_OBJ.format(name=name))
            archive.writestr(f"cat/{name}/{name}.mtl", "newmtl skin\nKd 1 1 1\nmap_Kd skin.png\n")
            archive.writestr(f"cat/{name}/skin.png", _png(0 if shared_texture and k < 2 else k))
            lines += [f"id#{k}=Test#{name}", f"name#{k}=Prop {k}", f"category#{k}=Misc", f"model#{k}=/cat/{name}/{name}.obj",
                      f"width#{k}={340 if k % 5 == 4 else 50}", f"height#{k}=120", f"depth#{k}={300 if k % 5 == 4 else 80}",
                      f"elevation#{k}={30 if k == 3 else 0}"]  # every fifth prop as wide as a room allows
        archive.writestr("PluginFurnitureCatalog.properties", "\n".join(lines) + "\n")
    return path


@pytest.fixture
def test_catalog(tmp_path, monkeypatch):
    path = write_catalog(tmp_path / "test.sh3f")
    monkeypatch.setenv("MNSS_KIT_CATALOG", str(path))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    catalog._catalog.cache_clear()
    catalog._loaded.cache_clear()
    yield path
    catalog._catalog.cache_clear()
    catalog._loaded.cache_clear()


def test_the_splits_are_disjoint_and_share_no_texture(test_catalog):
    train, unseen = catalog.props("train"), catalog.props("unseen")
    assert train and unseen and not {p.id for p in train} & {p.id for p in unseen}
    assert all(catalog.split_of(p.id) == "train" for p in train) and all(catalog.split_of(p.id) == "unseen" for p in unseen)
    trained = {h for p in train for h in catalog.texture_hashes(p)}
    assert not trained & {h for p in unseen for h in catalog.texture_hashes(p)}
    # prop0 and prop1 share their texture: when they fall in different splits the unseen one is left out
    first, second = (catalog.split_of(f"Test#prop{k}") for k in (0, 1))
    if first != second:
        left_out = "Test#prop0" if first == "unseen" else "Test#prop1"
        assert left_out not in {p.id for p in unseen}
    assert len(catalog.surface_textures("train")) >= 1


def test_a_prop_has_the_catalogue_size_and_stands_on_the_floor(test_catalog):
    by_id = {p.id: p for s in catalog.SPLITS for p in catalog.props(s)}
    for key, elevation in (("Test#prop5", 0.0), ("Test#prop3", 0.3)):
        if key not in by_id:
            continue
        points = np.concatenate([m.positions for m in catalog.prop_meshes(by_id[key])])
        np.testing.assert_allclose(points.min(0), [-0.25, elevation, -0.4], atol=1e-5)
        np.testing.assert_allclose(points.max(0), [0.25, elevation + 1.2, 0.4], atol=1e-5)
    assert not list((test_catalog.parent / "cache").rglob(".unpack-*"))  # nothing half-unpacked is left


def test_a_missing_or_corrupt_catalogue_is_a_one_line_error(tmp_path, monkeypatch):
    catalog._catalog.cache_clear()
    monkeypatch.setenv("MNSS_KIT_CATALOG", str(tmp_path / "absent.sh3f"))
    with pytest.raises(UserError, match="apt-get install sweethome3d-furniture"):
        catalog.props("train")
    (tmp_path / "bad.sh3f").write_bytes(b"not a zip")
    monkeypatch.setenv("MNSS_KIT_CATALOG", str(tmp_path / "bad.sh3f"))
    with pytest.raises(UserError, match="unreadable"):
        catalog.props("train")
    catalog._catalog.cache_clear()


def _inside_a_wall(x: float, z: float) -> bool:
    """Whether (x, z) lies in a wall of the rooms compound (doorways excepted)."""
    for along, across in ((x, z), (z, x)):  # walls at across = const, running along `along`
        for k in range(rooms.GRID + 1):
            if abs(across - (k - rooms.GRID / 2) * rooms.ROOM) > rooms.WALL / 2:
                continue
            inner = 0 < k < rooms.GRID
            in_door = any(abs(along - (r - (rooms.GRID - 1) / 2) * rooms.ROOM) < rooms.DOOR / 2 for r in range(rooms.GRID))
            if not (inner and in_door):
                return True
    return False


@pytest.mark.parametrize("split", catalog.SPLITS)
def test_the_rooms_camera_follows_through_doorways_and_cuts_once(test_catalog, split):
    duration = 3.0
    scene = rooms.build(7, duration, 0.0, None, False, False, split=split)
    assert scene.name == ("rooms" if split == "train" else "rooms_unseen")
    assert len(scene.camera.cut_times) == 1 and 0 < scene.camera.cut_times[0] < duration
    half = rooms.GRID * rooms.ROOM / 2
    for t in np.linspace(0.0, duration, 91):
        x, y, z = scene.camera.state(float(t)).position
        assert abs(x) < half and abs(z) < half and 0.5 < y < rooms.WALL_HEIGHT
        assert not _inside_a_wall(x, z), f"camera inside a wall at t={t:.2f}: {x:.2f}, {z:.2f}"
    assert any(i.transform is not None and callable(i.transform) for i in scene.instances)  # props and the runner move


def test_the_installed_catalogue_splits_share_no_mesh_or_texture():
    if not catalog.DEFAULT_CATALOG.is_file():
        pytest.skip("sweethome3d-furniture is not installed (scripts/setup.sh installs it as root)")
    catalog._catalog.cache_clear()
    train, unseen = catalog.props("train"), catalog.props("unseen")
    assert len(train) >= 60 and len(unseen) >= 30
    assert not {p.folder for p in train} & {p.folder for p in unseen}
    assert not {h for p in train for h in catalog.texture_hashes(p)} & {h for p in unseen for h in catalog.texture_hashes(p)}
