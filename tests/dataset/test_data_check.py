"""``mnss-kit data check`` and ``data info`` through the CLI, on broken copies of the synthetic dataset."""

import json
import re
import shutil

import numpy as np
import pytest

from mnss_kit import cli
from mnss_kit.dataset.format import read_raw_buffer, write_buffer
from mnss_kit.dataset.exr import write_exr


@pytest.fixture
def dataset(synthetic_dataset, tmp_path):
    return shutil.copytree(synthetic_dataset, tmp_path / "data", ignore=shutil.ignore_patterns(".cache"))


def run(capsys, *args):
    code = cli.main(["data", *map(str, args)])
    out = capsys.readouterr().out.splitlines()
    return code, out


def edit_meta(seq_dir, change):
    path = seq_dir / "meta.json"
    meta = json.loads(path.read_text())
    change(meta)
    path.write_text(json.dumps(meta))


def delete_frame(d):
    (d / "pan" / "lr" / "color" / "00003.exr").unlink()


def nan_pixel(d):
    img = read_raw_buffer(d / "pan", "hr", "reference", 2)
    img[10, 20, 0] = np.nan
    write_buffer(d / "pan", "hr", "reference", 2, img)


def wrong_size(d):
    write_buffer(d / "pan_cut", "lr", "depth", 4, np.ones((24, 30, 1), np.float32))


def truncated(d):
    path = d / "pan_cut" / "lr" / "motion" / "00001.exr"
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def garbage(d):
    (d / "pan" / "hr" / "depth" / "00006.exr").write_bytes(b"not an exr at all" * 10)


def bad_meta_key(d):
    edit_meta(d / "pan", lambda m: m.update(colour_space="linear"))


def wrong_scale(d):
    edit_meta(d / "pan", lambda m: m.update(scale=3, hr_size=[96, 72]))


def inconsistent_scale(d):
    edit_meta(d / "pan_cut", lambda m: m.update(scale=3))


def jitter_in_hr_pixels(d):
    def change(m):
        for f in m["frames"]:
            f["jitter"] = [2 * f["jitter"][0], 2 * f["jitter"][1]]

    edit_meta(d / "pan", change)


def hardware_depth(d):
    edit_meta(d / "pan", lambda m: m.update(depth_encoding="hardware"))


BROKEN = {
    "missing frame": (delete_frame, r"error: pan/lr/color/00003\.exr: missing frame"),
    "nan pixel": (nan_pixel, r"error: pan/hr/reference/00002\.exr: 1 NaN/Inf value\(s\), first at x=20 y=10"),
    "wrong size": (wrong_size, r"error: pan_cut/lr/depth/00004\.exr: size 30x24 does not match meta lr_size 32x24"),
    "truncated exr": (truncated, r"error: pan_cut/lr/motion/00001\.exr: .*corrupt or truncated"),
    "garbage exr": (garbage, r"error: pan/hr/depth/00006\.exr: not a readable OpenEXR file"),
    "bad meta key": (bad_meta_key, r"error: pan/meta\.json: unknown key 'colour_space' \(allowed: .*color_space"),
    "inconsistent scale": (inconsistent_scale, r"error: pan_cut/meta\.json: .*hr_size \(64, 48\) is not scale 3 x lr_size"),
    "jitter range": (jitter_in_hr_pixels, r"error: pan/meta\.json: jitter of \d+ frame\(s\) outside \[-0\.5, 0\.5\)"),
    "hardware depth": (hardware_depth, r"error: pan/lr/depth/00000\.exr: hardware depth outside \[0, 1\]"),
}


def test_clean_dataset_passes(capsys, synthetic_dataset):
    code, out = run(capsys, "check", synthetic_dataset)
    assert code == 0
    assert out[-1].startswith("data check OK: 2 sequence(s), 16 frames, 96 files checked: 0 error(s), 0 warning(s)")
    assert out[:-1] == ["note: 2 sequence(s) lack buffers the fusesr family reads (--family fusesr lists them)"]


def test_family_names_the_buffers_it_lacks(capsys, synthetic_dataset):
    code, out = run(capsys, "check", "--quick", synthetic_dataset, "--family", "mnss")
    assert code == 0 and len(out) == 2  # the fusesr note, then OK
    code, out = run(capsys, "check", "--quick", synthetic_dataset, "--family", "fusesr")
    assert code == 1 and out[-1].startswith("data quick check FAILED: 2 sequence(s)")
    assert re.fullmatch(r"error: pan(_cut)?/meta\.json: the fusesr family reads lr/fbeta, lr/emissive, hr/fbeta, "
                        r"hr/emissive, hr/normal, hr/albedo, which this sequence lacks \(docs/dataset\.md .*\)", out[0])


@pytest.mark.parametrize("name", BROKEN)
def test_each_problem_fails_with_one_line(capsys, dataset, name):
    breaker, expected = BROKEN[name]
    breaker(dataset)
    code, out = run(capsys, "check", dataset)
    assert code == 1, out
    errors = [line for line in out if line.startswith("error:")]
    assert any(re.match(expected, line) for line in errors), out
    assert "FAILED" in out[-1]


def test_wrong_scale_names_the_likely_cause(capsys, dataset):
    wrong_scale(dataset)
    code, out = run(capsys, "check", dataset, "--max-lines", "2")
    assert code == 1
    assert re.match(r"error: pan/hr/reference/00000\.exr: size 64x48 does not match meta hr_size 96x72 \(it is 2x lr_size: is meta scale 3 wrong\?\)", out[0])
    assert len(out) == 4 and out[2].startswith("... and ") and "FAILED" in out[3]  # capped, with a count


def test_motion_in_wrong_units_is_an_error(capsys, dataset):
    edit_meta(dataset / "pan", lambda m: m["motion"].update(units="uv"))
    code, out = run(capsys, "check", dataset / "pan")
    assert code == 1
    assert any(re.match(r"error: pan/lr/motion/00001\.exr: motion of 100% of pixels exceeds half the image", line) for line in out)


def test_only_long_motion_that_lands_inside_the_previous_frame_warns(capsys, dataset):
    """A pixel whose motion points off the previous frame came into view (a fast turn; the motion
    convention for a surface behind the previous camera): no warning however long it is.  Motion
    over half the image that lands inside the previous frame is suspect and warns."""
    from mnss_kit.dataset.check import canonical_motion
    from mnss_kit.dataset.format import read_meta

    seq = dataset / "pan"
    raw = read_raw_buffer(seq, "lr", "motion", 1)
    w, h = read_meta(seq).lr_size
    unit = canonical_motion(np.ones_like(raw), read_meta(seq), (w, h))[0, 0]  # canonical pixels per raw unit, per axis
    raw[:, :2, 0] = -10.0 * w / unit[0]  # the left columns came from far off the left edge
    write_buffer(seq, "lr", "motion", 1, raw)
    code, out = run(capsys, "check", seq)
    assert code == 0 and not any("half the image" in line for line in out), out
    raw[:2, :2, 0] = 0.75 * w / unit[0]  # four pixels from three quarters of the image to the right: inside
    write_buffer(seq, "lr", "motion", 1, raw)
    code, out = run(capsys, "check", seq)
    assert code == 0
    assert any(re.match(r"warning: pan/lr/motion/00001\.exr: 4 pixel\(s\) move more than half the image .* inside", line)
               for line in out), out


def test_long_motion_the_reference_bears_out_does_not_warn(capsys, dataset):
    """A fast pan: the left part of frame 1 is frame 0's reference from 60% of the image to the right,
    and its motion says so.  The reference bears the long motion out, so no warning; the same motion
    over a reference it does not follow (the frame upside down) warns."""
    from mnss_kit.dataset.check import canonical_motion
    from mnss_kit.dataset.format import read_meta

    seq = dataset / "pan"
    meta = read_meta(seq)
    (w, h), s = meta.lr_size, meta.scale
    shift = round(0.6 * w)  # LR pixels: more than half the image
    raw = read_raw_buffer(seq, "lr", "motion", 1)
    unit = canonical_motion(np.ones_like(raw), meta, (w, h))[0, 0]
    raw[..., :2] = 0.0  # the right part of the image stands still (under half moves: not the units error)
    raw[:, : w - shift, 0] = shift / unit[0]
    write_buffer(seq, "lr", "motion", 1, raw)
    panned = read_raw_buffer(seq, "hr", "reference", 1)
    panned[:, : (w - shift) * s] = read_raw_buffer(seq, "hr", "reference", 0)[:, shift * s :]
    write_buffer(seq, "hr", "reference", 1, panned)
    code, out = run(capsys, "check", seq)
    assert code == 0 and not any("lr/motion/00001.exr" in line for line in out), out
    write_buffer(seq, "hr", "reference", 1, panned[::-1].copy())
    code, out = run(capsys, "check", seq)
    assert code == 0
    assert any(re.match(r"warning: pan/lr/motion/00001\.exr: \d+ pixel\(s\) move more than half the image .* "
                        r"the reference does not follow them", line) for line in out), out


@pytest.mark.parametrize(
    "change, expected",
    [
        ({"points_to": "current"}, "works better with the motion negated"),
        ({"y_axis": "up"}, "works better with the motion with y negated"),
        ({"scale": 2.0}, "works better with the motion divided by the scale"),
    ],
)
def test_motion_convention_mistakes_warn(capsys, dataset, change, expected):
    edit_meta(dataset / "pan", lambda m: m["motion"].update(change))
    code, out = run(capsys, "check", dataset / "pan")
    assert code == 0  # heuristics warn, they do not fail
    assert [line for line in out if line.startswith("warning:")] and expected in out[0], out


def test_a_still_camera_with_rounded_motion_does_not_warn(capsys, dataset):
    """A still camera whose packed motion rounds to a hundredth of a pixel (8-bit pairs do): the
    reference reprojects better unmoved, but no pixel moves far enough to tell a sign mistake, so
    the sign heuristic has nothing to say."""
    from mnss_kit.dataset.format import read_meta

    seq = dataset / "pan"
    still = read_raw_buffer(seq, "hr", "reference", 0)
    for t in range(1, read_meta(seq).frame_count):
        write_buffer(seq, "hr", "reference", t, still)
        raw = read_raw_buffer(seq, "lr", "motion", t)
        raw[..., :2] = 0.0113
        write_buffer(seq, "lr", "motion", t, raw)
    code, out = run(capsys, "check", seq)
    assert code == 0 and not any("reprojecting the reference" in line for line in out), out


def test_negated_jitter_warns(capsys, dataset):
    def negate(m):
        for f in m["frames"]:
            f["jitter"] = [-f["jitter"][0], -f["jitter"][1]]

    edit_meta(dataset / "pan", negate)
    code, out = run(capsys, "check", dataset)
    assert code == 0
    assert any("the 'grid' pattern negated" in line for line in out)
    assert any(line.startswith("warning: pan: LR colour matches the reference better with the jitter negated") for line in out)


def test_quick_reads_headers_only(capsys, dataset):
    nan_pixel(dataset)
    code, out = run(capsys, "check", dataset, "--quick")
    assert code == 0 and out[-1].startswith("data quick check OK")
    delete_frame(dataset)
    code, out = run(capsys, "check", dataset, "--quick")
    assert code == 1 and out[0] == "error: pan/lr/color/00003.exr: missing frame"


def test_extra_and_unlisted_files_warn(capsys, dataset):
    write_exr(dataset / "pan" / "lr" / "color" / "00099.exr", np.zeros((24, 32, 3), np.float32))
    write_exr(dataset / "pan" / "lr" / "albedo" / "00000.exr", np.zeros((24, 32, 3), np.float32))
    code, out = run(capsys, "check", dataset, "--quick")
    assert code == 0
    assert "warning: pan/lr/color: 1 file(s) with no frame in meta.json (e.g. 00099.exr): ignored" in out
    assert "warning: pan/lr/albedo: not listed in meta.json buffers.lr: ignored by the loader" in out


def test_info_prints_each_sequence(capsys, synthetic_dataset):
    code, out = run(capsys, "info", synthetic_dataset)
    assert code == 0
    assert out[0].split()[:4] == ["sequence", "frames", "lr", "hr"]
    assert out[1].split()[:5] == ["pan", "8", "32x24", "64x48", "2"]
    assert out[2].split()[:7] == ["pan_cut", "8", "32x24", "64x48", "2", "grid", "2"]
    assert re.fullmatch(r"fingerprint: [0-9a-f]{64}", out[-1])


def test_not_a_dataset_exits_2(capsys, tmp_path):
    assert cli.main(["data", "check", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no dataset sequences" in err[0]


def test_example_meta_in_the_docs_is_valid():
    from pathlib import Path

    from mnss_kit.config import from_dict
    from mnss_kit.dataset.format import SequenceMeta

    doc = (Path(__file__).resolve().parents[2] / "docs" / "dataset.md").read_text()
    example = re.search(r"```json\n(.*?)```", doc, re.S).group(1)
    meta = from_dict(SequenceMeta, json.loads(example), source="docs/dataset.md")
    assert meta.hr_size == (meta.lr_size[0] * meta.scale, meta.lr_size[1] * meta.scale)
