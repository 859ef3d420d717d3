"""``mnss-kit data import images``: per-buffer image files and a mapping YAML into the dataset format."""

import numpy as np
import pytest
import yaml

from mnss_kit import cli
from mnss_kit.config import resolve_config_path
from mnss_kit.dataset.exr import write_exr
from mnss_kit.dataset.format import find_sequences, read_buffer, read_meta, read_raw_buffer
from mnss_kit.ops.jitter import jitter_sequence

from capture_helpers import write_packed_capture, write_png

LR = (16, 12)


def run_import(capsys, src, out, mapping):
    code = cli.main(["data", "import", "images", str(src), "--out", str(out), "--mapping", str(mapping)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_packed8_example_mapping_reproduces_motion_depth_and_colour(tmp_path, capsys):
    cap = write_packed_capture(tmp_path / "cap", lr_size=LR, frames=4, cut_at=2)
    code, out, err = run_import(capsys, tmp_path / "cap", tmp_path / "out", "packed8")
    assert code == 0, err
    (seq,) = find_sequences(tmp_path / "out")
    meta = read_meta(seq)
    assert (meta.scale, meta.lr_size, meta.color_space) == (2, LR, "display")
    assert (meta.depth_encoding, meta.reverse_z, meta.near, meta.far) == ("hardware", True, 0.1, 100.0)
    assert [f.reset for f in meta.frames] == [True, False, True, False]
    assert [f.jitter for f in meta.frames] == [tuple(j) for j in cap["jitter"]]
    for t in range(4):
        motion = read_buffer(seq, meta, "lr", "motion", t)
        assert np.abs(motion - cap["motion_px"][t]).max() <= np.array(LR).max() / 255.0**2
        # depth and colour: the 8-bit codes, exactly, as unorm values with the conventions in meta.json
        assert np.array_equal(read_raw_buffer(seq, "lr", "depth", t), cap["depth"][t] / np.float32(255))
        assert np.array_equal(np.round(read_raw_buffer(seq, "lr", "color", t) * 255), cap["color"][t])
        assert np.array_equal(np.round(read_raw_buffer(seq, "hr", "reference", t) * 255), cap["reference"][t])


def test_packed_motion_is_exact_to_the_layout_definition(tmp_path, capsys):
    """Known RGBA8 codes decode to the layout's definition, (2u - 1) w and -(2v - 1) h pixels, previous -> current."""
    cap = write_packed_capture(tmp_path / "cap", lr_size=LR, frames=2)
    rgba = np.zeros((LR[1], LR[0], 4), np.uint8)
    rgba[...] = (128, 0, 127, 128)
    write_png(cap["seq"] / "lr/motion/0001.png", rgba)
    assert run_import(capsys, tmp_path / "cap", tmp_path / "out", "packed8")[0] == 0
    (seq,) = find_sequences(tmp_path / "out")
    motion = read_buffer(seq, read_meta(seq), "lr", "motion", 1)
    u, v = 128 / 255, 127 / 255 + 128 / 255**2
    expected = -np.array([(2 * u - 1) * LR[0], -(2 * v - 1) * LR[1]])  # current -> previous, +y down
    np.testing.assert_allclose(motion[0, 0], expected, atol=1e-5)


def write_mapping(tmp_path, change):
    data = yaml.safe_load(resolve_config_path("packed8", "import").read_text())
    change(data)
    path = tmp_path / "mapping.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_sixteen_bit_png_exr_and_npy_buffers(tmp_path, capsys):
    cap = write_packed_capture(tmp_path / "cap", lr_size=LR, frames=2)
    rng = np.random.default_rng(3)
    depth16 = rng.integers(0, 65536, (2, LR[1], LR[0], 1), dtype=np.uint16)
    motion = rng.uniform(-3, 3, (2, LR[1], LR[0], 2)).astype(np.float32)
    ref16 = rng.integers(0, 65536, (2, LR[1] * 2, LR[0] * 2, 3), dtype=np.uint16)
    hr_motion = rng.uniform(-6, 6, (2, LR[1] * 2, LR[0] * 2, 2)).astype(np.float32)
    for t in range(2):
        write_png(cap["seq"] / f"d16/{t:04d}.png", depth16[t], bits=16)
        np.save(cap["seq"] / f"mv_{t}.npy", motion[t])
        write_png(cap["seq"] / f"ref16/{t:04d}.png", ref16[t], bits=16)
        write_exr(cap["seq"] / f"hr_mv/{t:04d}.exr", hr_motion[t], half=False)

    def change(m):
        m["buffers"]["lr/depth"] = {"file": "d16/{frame:04d}.png", "decode": "unorm", "encoding": "hardware"}
        m["buffers"]["lr/motion"] = {"file": "mv_{frame}.npy", "decode": "raw", "units": "pixels"}
        m["buffers"]["hr/reference"] = {"file": "ref16/{frame:04d}.png", "space": "display"}
        m["buffers"]["hr/motion"] = {"file": "hr_mv/{frame:04d}.exr", "decode": "raw"}
        m["jitter"] = {"pattern": "grid"}  # no file: the offsets of the toolkit's pattern

    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out", write_mapping(tmp_path, change))
    assert code == 0, err
    (seq,) = find_sequences(tmp_path / "out")
    meta = read_meta(seq)
    assert meta.motion.units == "pixels" and not meta.reverse_z
    assert [f.jitter for f in meta.frames] == [tuple(j) for j in jitter_sequence("grid", 2, 2)]
    for t in range(2):
        np.testing.assert_array_equal(read_buffer(seq, meta, "lr", "motion", t), motion[t])
        np.testing.assert_array_equal(read_buffer(seq, meta, "hr", "motion", t), hr_motion[t])
        np.testing.assert_allclose(read_raw_buffer(seq, "lr", "depth", t), depth16[t] / 65535.0, atol=1e-7)
        np.testing.assert_allclose(read_raw_buffer(seq, "hr", "reference", t), ref16[t] / 65535.0, atol=5e-4)  # half


def unknown_decode(m):
    m["buffers"]["lr/motion"]["decode"] = "rgba8_packed"


def unknown_buffer(m):
    m["buffers"]["lr/mask"] = {"file": "lr/mask/{frame:04d}.png"}


def missing_buffer(m):
    del m["buffers"]["hr/reference"]


def misplaced_key(m):
    m["buffers"]["lr/color"]["units"] = "uv"


def unknown_key(m):
    m["jitter"]["offset"] = 0.5


def no_jitter_source(m):
    m["jitter"] = {"units": "lr_pixels"}


@pytest.mark.parametrize("change, message", [
    (unknown_decode, "buffers.lr/motion.decode: unknown decode rule 'rgba8_packed' (known: unorm, raw, rgba8_pair)"),
    (unknown_buffer, "unknown buffer 'lr/mask'"),
    (missing_buffer, "buffers has no 'hr/reference'"),
    (misplaced_key, "buffers.lr/color.units does not apply to a color buffer"),
    (unknown_key, "unknown key 'jitter.offset'"),
    (no_jitter_source, "jitter needs a file, or a pattern the offsets are generated from (grid, halton, center)"),
], ids=lambda v: getattr(v, "__name__", ""))
def test_bad_mappings_fail_in_one_line(tmp_path, capsys, change, message):
    write_packed_capture(tmp_path / "cap", lr_size=LR, frames=2)
    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out", write_mapping(tmp_path, change))
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists()


def wrong_hr_size(seq):
    write_png(seq / "hr/color/0001.png", np.zeros((24, 30, 3), np.uint8))


def odd_hr_size(seq):
    write_png(seq / "hr/color/0001.png", np.zeros((24, 33, 3), np.uint8))


def wrong_lr_size(seq):
    write_png(seq / "lr/depth/0002.png", np.zeros((12, 15, 1), np.uint8))


def gap(seq):
    (seq / "lr/color/0001.png").unlink()


def motion_not_rgba(seq):
    write_png(seq / "lr/motion/0000.png", np.zeros((12, 16, 3), np.uint8))


def short_jitter(seq):
    np.savetxt(seq / "jitter.txt", np.zeros((2, 2)))


@pytest.mark.parametrize("damage, message", [
    (wrong_hr_size, "hr/color/0001.png: size 30x24, expected 32x24 (scale 2 x the LR size 16x12)"),
    (odd_hr_size, "hr/color/0001.png: size 33x24 is not divisible by scale 2"),
    (wrong_lr_size, "lr/depth/0002.png: size 15x12, expected 16x12 (the size of lr/color)"),
    (gap, "lr/color/0001.png: missing frame"),
    (motion_not_rgba, "decode rgba8_pair needs an 8-bit RGBA image"),
    (short_jitter, "jitter.txt: expected one row 'x y' per frame (3 frames)"),
], ids=lambda v: getattr(v, "__name__", ""))
def test_bad_captures_fail_in_one_line_and_leave_nothing(tmp_path, capsys, damage, message):
    cap = write_packed_capture(tmp_path / "cap", lr_size=LR, frames=3)
    damage(cap["seq"])
    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out", "packed8")
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists() and not list(tmp_path.glob(".out.*"))


def test_fractional_scale_mapping(tmp_path, capsys):
    """``scale: 1.5``: the HR files set the display size, which round(hr / s) must map to the LR size."""
    cap = write_packed_capture(tmp_path / "cap", lr_size=LR, frames=2)
    reference = np.random.default_rng(5).integers(0, 256, (2, 18, 24, 3), dtype=np.uint8)
    for t in range(2):
        write_png(cap["seq"] / f"hr/color/{t:04d}.png", reference[t])
    mapping = write_mapping(tmp_path, lambda m: m.update(scale=1.5))
    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out", mapping)
    assert code == 0, err
    (seq,) = find_sequences(tmp_path / "out")
    meta = read_meta(seq)
    assert (meta.scale, meta.lr_size, meta.hr_size) == (1.5, LR, (24, 18))
    assert np.array_equal(np.round(read_raw_buffer(seq, "hr", "reference", 1) * 255), reference[1])
    write_png(cap["seq"] / "hr/color/0001.png", np.zeros((18, 26, 3), np.uint8))
    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out2", mapping)
    assert code == 2 and "hr/color/0001.png: size 26x18, expected 24x18 (the size of the first HR file)" in err
    write_png(cap["seq"] / "hr/color/0000.png", np.zeros((18, 26, 3), np.uint8))
    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out3", mapping)
    assert code == 2 and "size 26x18 at scale 1.5 gives LR 17x12" in err and len(err.strip().splitlines()) == 1
    for bad, message in ((0.5, "scale 0.5 is outside [1.25, 4]"), (1.0, "scale must be an integer >= 2"),
                         (9, "scale 9 is outside [1.25, 4]"), (float("nan"), "finite")):
        code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out4", write_mapping(tmp_path, lambda m: m.update(scale=bad)))
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
