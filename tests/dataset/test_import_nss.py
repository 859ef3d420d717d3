"""``mnss-kit data import nss``: an NSS capture written from its spec imports to the values it holds."""

import json

import numpy as np
import pytest

from mnss_kit import cli
from mnss_kit.dataset.exr import write_exr
from mnss_kit.dataset.format import find_sequences, read_buffer, read_meta, read_raw_buffer
from mnss_kit.ops.colour import to_display

from capture_helpers import write_nss_capture


def run_import(capsys, src, out, *extra):
    code = cli.main(["data", "import", "nss", str(src), "--out", str(out), *map(str, extra)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_import_reproduces_every_buffer_jitter_and_cut(tmp_path, capsys):
    cap = write_nss_capture(tmp_path / "cap", ratios=("2", "1_5"), frames=5, cut_at=3, exposure=1.5)
    code, out, err = run_import(capsys, tmp_path / "cap", tmp_path / "out")
    assert code == 0, err
    (frac,) = find_sequences(tmp_path / "out" / "x1_5")  # a quality mode: imported at scale 1.5
    frac_meta = read_meta(frac)
    assert (frac_meta.scale, frac_meta.lr_size, frac_meta.hr_size) == (1.5, (21, 11), (32, 16))
    assert np.array_equal(read_raw_buffer(frac, "lr", "color", 2), cap["x1_5/color"][2][..., :3])
    assert frac_meta.frames[1].jitter == (cap["json"]["Frames"][1]["NormalizedPerRatioJitter"][1]["X"] * 21,
                                          cap["json"]["Frames"][1]["NormalizedPerRatioJitter"][1]["Y"] * 11)
    (seq,) = find_sequences(tmp_path / "out" / "x2")
    meta = read_meta(seq)
    assert (meta.scale, meta.lr_size, meta.hr_size) == (2, (16, 8), (32, 16))
    assert (meta.near, meta.far, meta.reverse_z, meta.depth_encoding) == (0.5, 50.0, False, "hardware")
    assert (meta.color_space, meta.exposure) == ("linear_hdr", 1.5)
    assert [f.reset for f in meta.frames] == [True, False, False, True, False]
    for i, frame in enumerate(cap["json"]["Frames"]):
        expected = frame["NormalizedPerRatioJitter"][0]
        assert frame["Jitter"] == {"X": expected["X"] * 16, "Y": expected["Y"] * 8}  # the spec's own relation
        assert meta.frames[i].jitter == (frame["Jitter"]["X"], frame["Jitter"]["Y"])  # exactly
        # colour: half floats copied exactly, then tone mapped with the recorded exposure
        assert np.array_equal(read_raw_buffer(seq, "lr", "color", i), cap["x2/color"][i][..., :3])
        np.testing.assert_allclose(read_buffer(seq, meta, "hr", "reference", i),
                                   to_display(cap["ground_truth"][i][..., :3], 1.5), atol=1e-6)
        # motion: UV, pointing to the previous frame, +y down -> LR pixels
        np.testing.assert_allclose(read_buffer(seq, meta, "lr", "motion", i),
                                   cap["x2/motion"][i] * np.array([16, 8], np.float32), atol=1e-3)
        np.testing.assert_allclose(read_buffer(seq, meta, "hr", "motion", i),
                                   cap["motion_gt"][i] * np.array([32, 16], np.float32), atol=1e-3)
        n, f = 0.5, 50.0  # forward hardware depth d = f (z - n) / (z (f - n)) -> canonical (z - n) / (f - n)
        z = n * f / (f - cap["x2/depth"][i].astype(np.float64) * (f - n))
        np.testing.assert_allclose(read_buffer(seq, meta, "lr", "depth", i), (z - n) / (f - n), atol=1e-6)


def test_infinite_far_becomes_linear_depth_with_the_near_plane(tmp_path, capsys):
    cap = write_nss_capture(tmp_path / "cap", far=-1.0, reverse_z=True, near=0.25)
    assert run_import(capsys, tmp_path / "cap", tmp_path / "out")[0] == 0
    (seq,) = find_sequences(tmp_path / "out" / "x2")
    meta = read_meta(seq)
    assert meta.depth_encoding == "linear" and meta.near == 0.25
    for i in range(len(cap["json"]["Frames"])):
        # reversed infinite projection: d = near / z
        np.testing.assert_allclose(read_raw_buffer(seq, "lr", "depth", i)[..., 0],
                                   np.minimum(0.25 / cap["x2/depth"][i][..., 0], meta.far), rtol=1e-6)


def test_changing_exposure_is_baked_into_the_colour_once(tmp_path, capsys):
    cap = write_nss_capture(tmp_path / "cap", frames=3, exposure=[1.0, 2.0, 0.5])
    assert run_import(capsys, tmp_path / "cap", tmp_path / "out")[0] == 0
    (seq,) = find_sequences(tmp_path / "out" / "x2")
    meta = read_meta(seq)
    assert meta.exposure == 1.0 and meta.scene["exposure_baked_into_colour"]
    np.testing.assert_allclose(read_raw_buffer(seq, "hr", "reference", 2), cap["ground_truth"][2][..., :3] * 0.5,
                               rtol=1e-3)


def drop_jitter_key(cap):
    meta = json.loads((cap / "0000.json").read_text())
    del meta["Frames"][2]["NormalizedPerRatioJitter"]
    (cap / "0000.json").write_text(json.dumps(meta))


def drop_version(cap):
    meta = json.loads((cap / "0000.json").read_text())
    del meta["Version"]
    (cap / "0000.json").write_text(json.dumps(meta))


def wrong_lr_size(cap):
    write_exr(cap / "x2" / "color" / "0000" / "0003.exr", np.zeros((8, 15, 4), np.float32))


def ratio_does_not_divide(cap):
    meta = json.loads((cap / "0000.json").read_text())
    meta["TargetResolution"]["X"] = 33
    (cap / "0000.json").write_text(json.dumps(meta))


def missing_frame(cap):
    """A file missing in the middle: pairing the rest by position would give them the wrong frames."""
    (cap / "motion_gt" / "0000" / "0002.exr").unlink()


def lfs_pointer(cap):
    (cap / "x2" / "color" / "0000" / "0001.exr").write_text(
        "version https://git-lfs.github.com/spec/v1\n"
        "oid sha256:4d7a214614ab2935c943f9e0ff69d22eadbb8f32b1258daaa5e2ca24d17e2393\nsize 24593\n")


def truncated_exr(cap):
    path = cap / "ground_truth" / "0000" / "0003.exr"
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def nan_colour(cap):
    write_exr(cap / "x2" / "color" / "0000" / "0001.exr", np.full((8, 16, 4), np.nan, np.float32))


@pytest.mark.parametrize("damage, message", [
    (drop_jitter_key, "0000.json: Frames[2]: missing key 'NormalizedPerRatioJitter'"),
    (drop_version, "0000.json: missing key 'Version'"),
    (wrong_lr_size, "0003.exr: size 15x8, expected 16x8"),
    (ratio_does_not_divide, "TargetResolution 33x16 is not divisible by ratio 2"),
    (missing_frame, "motion_gt/0000: frame file 0003.exr where"),
    (lfs_pointer, "x2/color/0000/0001.exr: a Git LFS pointer, not the image"),
    (truncated_exr, "ground_truth/0000/0003.exr: not a valid OpenEXR file"),
    (nan_colour, "fails data check (1 error(s)), first: error: x2/0000/lr/color/00001.exr: 384 NaN/Inf value(s)"),
], ids=lambda v: getattr(v, "__name__", ""))
def test_bad_captures_fail_in_one_line_and_leave_nothing(tmp_path, capfd, damage, message):
    """capfd: what the OpenEXR library itself writes to fd 1 and 2 counts too."""
    write_nss_capture(tmp_path / "cap")
    damage(tmp_path / "cap")
    code, out, err = run_import(capfd, tmp_path / "cap", tmp_path / "out")
    assert code == 2
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not out.strip(), out
    assert not (tmp_path / "out").exists()
    assert not list(tmp_path.glob(".out.*"))  # no staging directory left behind


def test_only_ratios_outside_the_quality_modes_is_refused(tmp_path, capsys):
    write_nss_capture(tmp_path / "cap", ratios=("1", "1_1"))
    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out")
    assert code == 2 and "no upscaling ratio of 2 or more or in [1.25, 4] (found x1_1, x1)" in err


def test_fractional_ratios_import_and_pass_data_check(tmp_path, capsys):
    write_nss_capture(tmp_path / "cap", hr_size=(34, 18), ratios=("1_7", "1_5", "1"), frames=4)
    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out")
    assert code == 0, err
    assert "x1: 4 frames found, not imported: ratio 1 does not upscale" in err
    for ratio, scale, lr in (("x1_7", 1.7, (20, 11)), ("x1_5", 1.5, (23, 12))):
        (seq,) = find_sequences(tmp_path / "out" / ratio)
        meta = read_meta(seq)
        assert (meta.scale, meta.lr_size, meta.hr_size) == (scale, lr, (34, 18))
        assert cli.main(["data", "check", str(seq), "--quick"]) == 0


def test_every_sequence_becomes_one_sequence_of_the_ratio_dataset(tmp_path, capsys):
    first = write_nss_capture(tmp_path / "cap", frames=3, sequence="0000", seed=1)
    second = write_nss_capture(tmp_path / "cap", frames=4, sequence="0001", seed=2)
    assert run_import(capsys, tmp_path / "cap", tmp_path / "out")[0] == 0
    seqs = find_sequences(tmp_path / "out" / "x2")
    assert [s.name for s in seqs] == ["0000", "0001"]
    assert [read_meta(s).frame_count for s in seqs] == [3, 4]
    for seq, cap in zip(seqs, (first, second)):
        assert np.array_equal(read_raw_buffer(seq, "lr", "motion", 2), cap["x2/motion"][2])


def arm_sample_layout(cap, present: int) -> None:
    """Arm's sample captures: the JSON lists every frame, the buffers ship only the first ones."""
    for folder in [p for p in cap.rglob("0000") if p.is_dir()]:
        for path in sorted(folder.glob("*.exr"))[present:]:
            path.unlink()


def test_arm_sample_layout_imports_the_frames_present_and_passes_data_check(tmp_path, capsys):
    cap = write_nss_capture(tmp_path / "cap", frames=5, cut_at=3)
    arm_sample_layout(tmp_path / "cap", 2)
    code, out, err = run_import(capsys, tmp_path / "cap", tmp_path / "out")
    assert code == 0, err
    assert "frame files for 2 of the 5 frames 0000.json lists (3 missing); imported frames 0..1" in err
    assert "imported 1 sequence(s), 2 frames" in out
    (seq,) = find_sequences(tmp_path / "out" / "x2")
    meta = read_meta(seq)
    assert meta.frame_count == 2 and meta.scene["frames_listed"] == 5
    for i in range(2):  # paired with the first Frames entries
        frame = cap["json"]["Frames"][i]
        assert meta.frames[i].jitter == (frame["Jitter"]["X"], frame["Jitter"]["Y"])
        assert np.array_equal(read_raw_buffer(seq, "lr", "color", i), cap["x2/color"][i][..., :3])
    assert cli.main(["data", "check", str(tmp_path / "out" / "x2")]) == 0


def test_a_buffer_with_more_files_than_frames_is_refused(tmp_path, capsys):
    write_nss_capture(tmp_path / "cap", frames=3)
    write_exr(tmp_path / "cap" / "x2" / "depth" / "0000" / "0003.exr", np.zeros((8, 16, 1), np.float32), half=False)
    code, _, err = run_import(capsys, tmp_path / "cap", tmp_path / "out")
    assert code == 2 and "x2/depth/0000: 4 frame file(s), but" in err and "lists 3 frames" in err
