"""Engine-convention variants: each motion and depth transform held to its definition
(``mnss_kit/dataset/engine_motion.py``, ``variants.py``), and the ``engine`` preset on a rendered
sequence with moving objects passes ``data check`` with no warnings."""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.cli import main
from mnss_kit.dataset import engine_motion as em
from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.check import check_dataset
from mnss_kit.dataset.variants import ENGINE, NEAR_GUESS_FACTOR, camera_motion, check_variants, write_variant_dataset


def _motion_field(h=12, w=20, seed=0):
    """Motion within half a screen either way (inside the packing's range)."""
    return (np.random.default_rng(seed).uniform(-0.5, 0.5, (h, w, 2)) * [w, h]).astype(np.float32)


def test_pack8_decodes_as_r_over_255_plus_g_over_255_squared():
    r, g = em.pack_motion8(np.array([0.0, -1.0, 1.0, 0.3]))
    assert r.dtype == np.uint8 and g.dtype == np.uint8
    u = r / 255.0 + g / 255.0**2
    np.testing.assert_allclose(em.unpack_motion8(r, g), 2.0 * u - 1.0)
    assert (r[1], g[1]) == (0, 0) and (r[2], g[2]) == (255, 0)  # the ends of the range


def test_pack8_round_trip_is_within_its_quantization_step():
    motion = _motion_field()
    size = np.array([20.0, 12.0])
    step_px = 2.0 / em.PACK8_LEVELS * size  # one level of u is 2 / 255^2 screens
    error = np.abs(em.packed8(motion) - motion)
    assert np.all(error <= step_px / 2 + 1e-5)
    assert error.max() > step_px.min() / 10  # it does quantize
    np.testing.assert_allclose(em.packed8(np.full((2, 20, 2), 100.0, np.float32)), np.broadcast_to([20.0, 2.0], (2, 20, 2)),
                               atol=1e-3)  # one screen at most


def test_half_rounds_uv_motion_to_float16():
    motion = _motion_field()
    size = np.array([20.0, 12.0])
    expected = (motion / size).astype(np.float16).astype(np.float64) * size
    np.testing.assert_allclose(em.half_float(motion), expected, rtol=1e-6)
    assert not np.array_equal(em.half_float(motion), motion)


def test_half_saturates_motion_beyond_its_range():
    motion = np.full((2, 4, 2), 1e9, np.float32)
    motion[0, 0] = -1e9
    with np.errstate(over="raise"):
        got = em.half_float(motion)
    assert np.isfinite(got).all()
    np.testing.assert_allclose(got[1, 1], em.HALF_MAX * np.array([4.0, 2.0]), rtol=1e-3)
    assert np.all(got[0, 0] < 0)


def test_dilation_takes_the_nearest_depth_neighbour():
    depth = np.full((5, 6), 0.5, np.float32)
    depth[2, 3] = 0.1  # one near pixel
    motion = _motion_field(5, 6)
    out = em.dilated(motion, depth)
    for y in range(5):
        for x in range(6):
            expected = motion[2, 3] if abs(y - 2) <= 1 and abs(x - 3) <= 1 else motion[y, x]  # flat depth: centre wins
            np.testing.assert_array_equal(out[y, x], expected)


def test_dilation_breaks_ties_by_row_major_order_and_clamps_at_the_border():
    depth = np.ones((3, 3), np.float32)
    depth[0, 0] = depth[0, 2] = 0.2  # two equally near pixels
    motion = _motion_field(3, 3)
    out = em.dilated(motion, depth)
    np.testing.assert_array_equal(out[1, 1], motion[0, 0])  # the earlier of the tie
    np.testing.assert_array_equal(out[0, 1], motion[0, 0])
    np.testing.assert_array_equal(out[2, 2], motion[2, 2])  # neighbours past the border are itself
    np.testing.assert_array_equal(out[1, 2], motion[0, 2])


def test_rigid_gives_each_object_its_median_and_absent_gives_zero():
    camera = np.zeros((8, 8, 2), np.float32)
    motion = camera.copy()
    motion[1:3, 1:4] = [[[3.0, 1.0], [4.0, 1.0], [5.0, 1.0]]] * 2  # a limb moving unevenly
    motion[6, 6] = [-2.0, 0.1]  # a second object
    labels, count = em.moving_objects(motion, camera)
    assert count == 2
    objects = [labels == 1, labels == 2]
    out = em.rigid(motion, objects)
    np.testing.assert_array_equal(out[1:3, 1:4], np.broadcast_to([4.0, 1.0], (2, 3, 2)))
    np.testing.assert_array_equal(out[labels == 0], motion[labels == 0])
    np.testing.assert_array_equal(em.absent(motion, objects[1:])[6, 6], [0.0, 0.0])


def test_object_cells_are_drawn_once_per_sequence():
    a, b = em.object_cells("town_test"), em.object_cells("town_test")
    np.testing.assert_array_equal(a, b)
    kinds = np.concatenate([em.object_cells(f"seq{i}").ravel() for i in range(200)])
    for kind, share in em.CELL_SHARES.items():
        assert abs(np.mean(kinds == kind) - share) < 0.03


def test_engine_preset_expands_and_exclusions_are_refused():
    assert check_variants(["engine"]) == list(ENGINE)
    with pytest.raises(Exception, match="one motion packing"):
        check_variants(["motion_pack8", "motion_half"])
    with pytest.raises(Exception, match="do not go together"):
        check_variants(["camera_motion", "motion_rigid"])


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """A few frames of a built-in scene with a moving camera and moving objects."""
    out = tmp_path_factory.mktemp("rendered") / "data"
    assert main(["render", "tiny_test", "--out", str(out), "--set", "frames=4", "--no-progress"]) == 0
    return out


def _motion(seq, i):
    meta = fmt.read_meta(seq)
    return fmt.read_buffer(seq, meta, "lr", "motion", i)


def test_engine_variant_changes_object_motion_and_passes_data_check(rendered, tmp_path):
    out = tmp_path / "engine"
    assert main(["data", "variant", str(rendered), "--out", str(out), "--apply", "engine"]) == 0
    report, source = check_dataset(out, progress=False), check_dataset(rendered, progress=False)
    assert not report.errors, [p.line() for p in report.errors]
    # no warning of its own: only where the rendered source already warns (motion past half the image)
    assert {p.where for p in report.warnings} <= {p.where for p in source.warnings}
    src, dst = fmt.find_sequences(rendered)[0], fmt.find_sequences(out)[0]
    meta, src_meta = fmt.read_meta(dst), fmt.read_meta(src)
    assert meta.near == pytest.approx(src_meta.near * NEAR_GUESS_FACTOR) and meta.reverse_z
    assert meta.scene["input_variants"] == list(ENGINE)
    raw = fmt.read_raw_buffer(dst, "lr", "depth", 1)
    np.testing.assert_allclose(raw * 255.0, np.round(raw * 255.0), atol=1e-2)  # 8-bit depth
    # the canonical depth under the guessed near plane keeps the order of the true depth
    a = fmt.read_buffer(src, src_meta, "lr", "depth", 1).ravel()
    b = fmt.read_buffer(dst, meta, "lr", "depth", 1).ravel()
    assert np.all(np.diff(b[np.argsort(a, kind="stable")]) >= -1e-6)
    changed = [np.abs(_motion(dst, i) - _motion(src, i)).max() for i in range(1, meta.frame_count)]
    assert max(changed) > 0.5  # objects lost their own motion somewhere


def test_motion_rigid_touches_only_moving_objects(rendered, tmp_path):
    out = tmp_path / "rigid"
    write_variant_dataset(rendered, out, ["motion_rigid"])
    src, dst = fmt.find_sequences(rendered)[0], fmt.find_sequences(out)[0]
    meta = fmt.read_meta(src)
    for i in range(1, meta.frame_count):
        cam = fmt.canonical_motion(camera_motion(src, meta, i), meta, meta.lr_size)
        labels, _ = em.moving_objects(_motion(src, i), cam)
        np.testing.assert_array_equal(_motion(dst, i)[labels == 0], _motion(src, i)[labels == 0])


def test_ldr8_converts_every_reference_to_display_space(tmp_path):
    src = tmp_path / "data"
    assert main(["render", "tiny_test", "--out", str(src), "--set", "frames=2", "--set", "extra_references=[taa,4x]",
                 "--no-progress"]) == 0
    write_variant_dataset(src, tmp_path / "v", ["ldr8"])
    for seq in fmt.find_sequences(tmp_path / "v"):
        meta, src_meta = fmt.read_meta(seq), fmt.read_meta(src / seq.name)
        assert meta.color_space == "display"
        for ref in fmt.REFERENCE_BUFFERS.values():
            assert ref in meta.buffers["hr"]
            np.testing.assert_allclose(fmt.read_buffer(seq, meta, "hr", ref, 1), fmt.read_buffer(src / seq.name, src_meta, "hr", ref, 1),
                                       atol=2e-3)
