"""Fractional scales (quality modes, issue 44) in the size rule, the jitter, the render config and
``mnss-kit render``: 1.5x and 1.7x renders pass ``data check``; integer scales render as before."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mnss_kit.cli import main
from mnss_kit.config import to_dict
from mnss_kit.dataset import format as fmt
from mnss_kit.errors import UserError
from mnss_kit.ops import scale as scales
from mnss_kit.ops.jitter import jitter_sequence, period
from mnss_kit.ops.resample import bilinear_sample, pixel_grid
from mnss_kit.render.config import load_render_config
from mnss_kit.render.run import render_dataset

CAMERA = """
keyframes:
  - {time: 0.5, position: [-10, 14, 12], look_at: [-9, 0, 0]}
  - {time: 0.7, position: [-6, 14, 11], look_at: [-4, 0, 0]}
"""

# 48x28 -> 72x42 at 1.5 (ratio exactly 3/2); 1.7 from the display size 80x45 (LR 47x26)
FRACTIONAL = """
version: 1
defaults: {lr_size: [48, 28], scale: 1.5, jitter: halton, hr_samples: 4, frames: 4, start_time: 0.5, camera: cam.yaml}
sequences:
  - {name: q15, scene: arena, seed: 11}
  - {name: b17, scene: arena, seed: 11, scale: 1.7, hr_size: [80, 45], frames: 3}
"""


def write_config(root, text: str) -> str:
    (root / "cam.yaml").write_text(CAMERA)
    path = root / "cfg.yaml"
    path.write_text(text)
    return str(path)


@pytest.fixture(scope="module")
def fractional_render(tmp_path_factory):
    root = tmp_path_factory.mktemp("fractional")
    render_dataset(load_render_config(write_config(root, FRACTIONAL)), root / "out", progress=False)
    return root / "out"


# -- the size rule -------------------------------------------------------------------------------

def test_display_size_gives_documented_render_sizes():
    assert scales.lr_size_for((1280, 720), 1.7) == (753, 424)  # 752.94, 423.53: rounded half up
    assert scales.lr_size_for((1280, 720), 1.5) == (853, 480)
    assert scales.lr_size_for((1920, 1080), 1.5) == (1280, 720)
    assert scales.lr_size_for((5, 5), 2) == (3, 3)  # 2.5: half up, not to even
    assert scales.axis_ratios((753, 424), (1280, 720)) == ((1280, 753), (90, 53))
    assert scales.as_fraction(1.7) == (17, 10) and scales.as_fraction(1.25) == (5, 4)


def test_lr_size_and_hr_size_give_each_other_back():
    for s in (1.25, 1.3, 1.5, 1.7, 2.5, 3.3):
        for lr in range(8, 200, 7):
            hr = scales.hr_size_for((lr, lr + 1), s)
            assert scales.lr_size_for(hr, s) == (lr, lr + 1)
            assert scales.size_mismatch((lr, lr + 1), hr, s) is None
    assert scales.hr_size_for((640, 360), 2) == (1280, 720)
    assert "is not scale 2" in scales.size_mismatch((640, 360), (1281, 720), 2)


def test_crop_step_is_the_ratio_denominator():
    assert scales.crop_step((48, 28), (72, 42)) == (2, 2)
    assert scales.crop_step((800, 450), (1360, 765)) == (10, 10)
    assert scales.crop_step((753, 424), (1280, 720)) == (753, 53)
    assert scales.crop_step((64, 36), (128, 72)) == (1, 1)


@pytest.mark.parametrize("bad", [0.5, 1.0, 1, float("nan"), float("inf"), 9, 4.5, "nan", "abc", True, 1.23456])
def test_bad_scales_are_refused(bad):
    with pytest.raises(UserError) as e:
        scales.parse_scale(bad)
    assert "\n" not in str(e.value)


def test_integral_scales_are_ints():
    assert scales.parse_scale(2.0) == 2 and isinstance(scales.parse_scale(2.0), int)
    assert scales.parse_scale("1.5") == 1.5 and isinstance(scales.parse_scale(1.7), float)


# -- jitter ---------------------------------------------------------------------------------------

def test_halton_phase_count_grows_with_the_scale():
    assert [period("halton", s) for s in (1.5, 1.7, 2, 3, 4)] == [18, 24, 32, 72, 128]  # ceil(8 s^2)
    j = jitter_sequence("halton", 1.7, 50)
    np.testing.assert_array_equal(j[24:48], j[:24])
    assert not np.array_equal(j[18:24], j[:6])
    assert j.min() >= -0.5 and j.max() < 0.5
    np.testing.assert_array_equal(jitter_sequence("center", 1.5, 3), np.zeros((3, 2)))


def test_integer_jitter_patterns_unchanged():
    # the published offsets: MNSS x2 sub-pixels (0,0) (1,1) (1,0) ...; Halton(2, 3) - 0.5 from index 1
    np.testing.assert_array_equal(jitter_sequence("grid", 2, 3), [[-0.25, -0.25], [0.25, 0.25], [0.25, -0.25]])
    np.testing.assert_allclose(jitter_sequence("halton", 2, 2), [[0.0, -1 / 6], [-0.25, 1 / 6]])
    assert period("grid", 2) == 12 and period("grid", 3) == 9 and period("halton", 2) == 32
    assert jitter_sequence("halton", 2.0, 40).tolist() == jitter_sequence("halton", 2, 40).tolist()
    with pytest.raises(UserError, match="grid jitter pattern exists for scales 2 and 3, not 1.5"):
        jitter_sequence("grid", 1.5, 4)


# -- render config ---------------------------------------------------------------------------------

def test_display_size_is_primary_in_a_config(tmp_path):
    text = ("version: 1\ndefaults: {lr_size: [320, 180], frames: 2, jitter: halton}\nsequences:\n"
            "  - {name: a, scene: arena, scale: 1.7, hr_size: [1280, 720]}\n  - {name: b, scene: arena}\n")
    a, b = load_render_config(write_config(tmp_path, text)).sequences
    assert (a.lr_size, a.hr_size, a.scale) == ((753, 424), (1280, 720), 1.7)
    assert (b.lr_size, b.hr_size, b.scale) == ((320, 180), (640, 360), 2)
    cfg = load_render_config(write_config(tmp_path, text), ["scale=1.5", "hr_size=[1920, 1080]"])
    assert [(s.lr_size, s.hr_size) for s in cfg.sequences] == [((1280, 720), (1920, 1080))] * 2
    cfg = load_render_config(write_config(tmp_path, text), ["scale=1.5"])
    assert cfg.sequences[1].lr_size == (320, 180) and cfg.sequences[1].hr_size == (480, 270)


@pytest.mark.parametrize("seq, message", [
    ("{name: a, scene: arena, scale: 1.7, hr_size: [1280, 720], lr_size: [752, 424]}", "disagree at scale 1.7"),
    ("{name: a, scene: arena, scale: 2, hr_size: [1281, 720]}", "not divisible by the integer scale 2"),
    ("{name: a, scene: arena, scale: 1.5, jitter: grid}", "sequence 'a': the grid jitter pattern exists for scales 2 and 3"),
    ("{name: a, scene: arena, scale: 0.5}", "scale 0.5 is outside"),
])
def test_bad_size_and_scale_combinations(tmp_path, seq, message):
    with pytest.raises(UserError, match=message):
        load_render_config(write_config(tmp_path, f"version: 1\nsequences:\n  - {seq}\n"))


@pytest.mark.parametrize("args", [["--scale", "0.5"], ["--scale", "1.0"], ["--scale", "nan"], ["--scale", "9"],
                                  ["--set", "scale=0.5"], ["--set", "scale=1"], ["--set", "scale=nan"], ["--set", "scale=9"]])
def test_render_cli_refuses_bad_scales_in_one_line(tmp_path, capsys, args):
    code = main(["render", write_config(tmp_path, FRACTIONAL), "--out", str(tmp_path / "out"), "--no-progress", *args])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "scale" in err and "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "out" / "q15" / "lr").exists()


# -- fractional renders ------------------------------------------------------------------------------

def test_fractional_renders_pass_data_check(fractional_render, capsys):
    code = main(["data", "check", str(fractional_render)])
    out = capsys.readouterr().out.strip().splitlines()
    assert code == 0 and out[-1].startswith("data check OK: 2 sequence(s), 7 frames")
    assert "0 error(s), 0 warning(s)" in out[-1]


def test_fractional_meta_and_buffer_sizes(fractional_render):
    q15, b17 = fmt.read_meta(fractional_render / "q15"), fmt.read_meta(fractional_render / "b17")
    assert (q15.scale, q15.lr_size, q15.hr_size) == (1.5, (48, 28), (72, 42))
    assert (b17.scale, b17.lr_size, b17.hr_size) == (1.7, (47, 26), (80, 45))
    assert b17.ratios == ((80, 47), (45, 26))
    np.testing.assert_allclose([f.jitter for f in b17.frames], jitter_sequence("halton", 1.7, 3))
    for meta, seq in ((q15, "q15"), (b17, "b17")):
        for res, (w, h) in (("lr", meta.lr_size), ("hr", meta.hr_size)):
            for name in meta.buffers[res]:
                assert fmt.read_raw_buffer(fractional_render / seq, res, name, 1).shape[:2] == (h, w)
    record = json.loads((fractional_render / "b17" / "meta.json").read_text())["scene"]
    assert record["hr_size"] == [80, 45] and record["lr_size"] == [47, 26] and record["scale"] == 1.7


def test_fractional_lr_colour_sits_at_the_jittered_positions(fractional_render):
    """The LR frame samples the HR frame's view at (pixel + 0.5 + jitter) * hr / lr per axis: the
    same field of view, the jitter in LR pixels."""
    seq = fractional_render / "b17"
    meta = fmt.read_meta(seq)
    rx, ry = (float(r) for r in meta.ratios)
    for t in (1, 2):  # Halton (-0.25, 0.17) and (0.25, -0.39)
        lr = fmt.read_buffer(seq, meta, "lr", "color", t)
        ref = fmt.read_buffer(seq, meta, "hr", "reference", t)
        x, y = pixel_grid(*lr.shape[:2])
        jx, jy = meta.frames[t].jitter
        err = {sign: float(np.mean(np.abs(bilinear_sample(ref, (x + sign * jx) * rx, (y + sign * jy) * ry) - lr)))
               for sign in (1.0, -1.0)}
        assert err[1.0] < 0.9 * err[-1.0]
        # and better than the unjittered pixel centres, or a view shifted by one LR pixel
        centre = float(np.mean(np.abs(bilinear_sample(ref, x * rx, y * ry) - lr)))
        shifted = float(np.mean(np.abs(bilinear_sample(ref, (x + jx + 1.0) * rx, (y + jy) * ry) - lr)))
        assert err[1.0] < centre and err[1.0] < 0.7 * shifted


def test_integer_scale_meta_is_as_before(tmp_path):
    """An integer-scale config writes the meta.json it wrote before fractional scales (no hr_size in the
    record, scale an integer), whichever way the size and scale are written; the cameras' aspect is the
    LR one to the last bit, so the frames are the same too."""
    from mnss_kit.render.scenes import build_scene
    from mnss_kit.render.run import frame_aspect, sequence_meta

    base = "version: 1\nsequences:\n  - {name: a, scene: arena, frames: 3, jitter: grid, %s}\n"
    metas = []
    for size in ("lr_size: [64, 36], scale: 2", "lr_size: [64, 36], scale: 2.0", "hr_size: [128, 72], scale: 2"):
        cfg = load_render_config(write_config(tmp_path, base % size))
        (seq,) = cfg.sequences
        record = sequence_meta(seq, build_scene(seq, cfg))
        metas.append(json.dumps(to_dict(record)))
        assert isinstance(seq.scale, int) and frame_aspect(seq) == seq.lr_size[0] / seq.lr_size[1]
        assert "hr_size" not in record.scene and record.scene["scale"] == 2 and record.scale == 2
    assert metas[0] == metas[1] == metas[2]
    for lw, lh in ((640, 360), (160, 90), (853, 480), (37, 23), (1001, 777)):
        for s in (2, 3, 4):
            assert (lw * s) / (lh * s) == lw / lh
