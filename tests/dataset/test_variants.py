"""Input variants (``mnss-kit data variant``): each rewrites what it says, keeps the rest, and the
result passes ``data check``; camera motion reproduces rendered motion on static geometry."""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.cli import main
from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.check import check_dataset
from mnss_kit.dataset.variants import camera_motion, write_variant_dataset


def _frames(seq, res, buffer):
    meta = fmt.read_meta(seq)
    return np.stack([fmt.read_buffer(seq, meta, res, buffer, i) for i in range(meta.frame_count)])


def test_ldr8_and_depth8_change_only_what_they_say(synthetic_dataset, tmp_path):
    out = tmp_path / "v"
    write_variant_dataset(synthetic_dataset, out, ["depth8", "ldr8"])
    src, dst = synthetic_dataset / "pan", out / "pan"
    meta = fmt.read_meta(dst)
    assert meta.color_space == "display" and meta.reverse_z and meta.depth_encoding == "hardware"
    assert meta.scene["input_variants"] == ["ldr8", "depth8"]  # application order
    colour = _frames(dst, "lr", "color")
    np.testing.assert_allclose(colour * 255.0, np.round(colour * 255.0), atol=0.1)  # 8-bit levels, stored as half floats
    np.testing.assert_allclose(colour, _frames(src, "lr", "color"), atol=0.5 / 255 + 2e-3)
    np.testing.assert_allclose(_frames(dst, "hr", "reference"), _frames(src, "hr", "reference"), atol=2e-3)
    raw = np.stack([fmt.read_raw_buffer(dst, "lr", "depth", i) for i in range(meta.frame_count)])
    np.testing.assert_allclose(raw * 255.0, np.round(raw * 255.0), atol=1e-2)
    # 8-bit reversed depth keeps near depth and loses far depth: the canonical depth differs, but in order
    src_depth, dst_depth = _frames(src, "lr", "depth"), _frames(dst, "lr", "depth")
    assert not np.allclose(src_depth, dst_depth, atol=1e-4)
    np.testing.assert_allclose(_frames(dst, "hr", "depth"), _frames(src, "hr", "depth"), atol=1e-3)  # HR unrounded
    np.testing.assert_array_equal(_frames(dst, "lr", "motion"), _frames(src, "lr", "motion"))
    report = check_dataset(out)
    assert not report.errors, [p.line() for p in report.errors]


def test_motion_noise_is_seeded_and_sized(synthetic_dataset, tmp_path):
    write_variant_dataset(synthetic_dataset / "pan", tmp_path / "a", ["motion_noise"])
    write_variant_dataset(synthetic_dataset / "pan", tmp_path / "b", ["motion_noise"])
    a, b = _frames(tmp_path / "a" / "pan", "lr", "motion"), _frames(tmp_path / "b" / "pan", "lr", "motion")
    np.testing.assert_array_equal(a, b)
    noise = a - _frames(synthetic_dataset / "pan", "lr", "motion")
    assert 0.2 < noise.std() < 0.3


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """A few frames of a built-in scene with a moving camera (the renderer's own motion vectors)."""
    out = tmp_path_factory.mktemp("rendered") / "data"
    assert main(["render", "tiny_test", "--out", str(out), "--set", "frames=3", "--no-progress"]) == 0
    return fmt.find_sequences(out)[0]


def test_camera_motion_matches_rendered_motion_on_static_geometry(rendered):
    meta = fmt.read_meta(rendered)
    for i in range(1, meta.frame_count):
        rendered_motion = fmt.canonical_motion(fmt.read_raw_buffer(rendered, "lr", "motion", i), meta, meta.lr_size)
        if not np.abs(rendered_motion).max() > 0.1:
            continue
        error = np.linalg.norm(fmt.canonical_motion(camera_motion(rendered, meta, i), meta, meta.lr_size) - rendered_motion, axis=-1)
        assert np.median(error) < 1e-3, (i, np.median(error))  # moving objects, a minority, differ
        return
    pytest.fail("the rendered sequence has no camera motion to compare")


@pytest.mark.parametrize("apply, message", [(["ldr9"], "unknown input variant 'ldr9'"),
                                            (["depth8", "depth16"], "one depth precision"), (["ldr8", "ldr8"], "each at most once")])
def test_bad_variants_are_one_line_errors(synthetic_dataset, tmp_path, capsys, apply, message):
    assert main(["data", "variant", str(synthetic_dataset), "--out", str(tmp_path / "o"), "--apply", *apply]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
