"""Fractional-scale data (issue 44) in the loader's crops, ``data check``, ``data info`` and eval:
crops at 1.5x land on whole HR pixels, bad scales are one-line errors, the bicubic baseline runs."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest
import torch

from mnss_kit.cli import main
from mnss_kit.dataset import format as fmt
from mnss_kit.dataset.loader import Crop, WindowDataset, hr_crop
from mnss_kit.errors import UserError

CAMERA = """
keyframes:
  - {time: 0.5, position: [-10, 14, 12], look_at: [-9, 0, 0]}
  - {time: 0.7, position: [-6, 14, 11], look_at: [-4, 0, 0]}
"""
# 48x28 -> 72x42 (ratio 3/2 on both axes); 1.7 from the display size 80x45 (47x26: 80/47, 45/26)
CONFIG = """
version: 1
defaults: {scale: 1.5, jitter: halton, hr_samples: 1, frames: 3, start_time: 0.5, camera: cam.yaml}
sequences:
  - {name: q15, scene: arena, seed: 11, lr_size: [48, 28]}
  - {name: b17, scene: arena, seed: 11, scale: 1.7, hr_size: [80, 45]}
"""


@pytest.fixture(scope="module")
def fractional_data(tmp_path_factory):
    from mnss_kit.render.config import load_render_config
    from mnss_kit.render.run import render_dataset

    root = tmp_path_factory.mktemp("fractional_data")
    (root / "cam.yaml").write_text(CAMERA)
    (root / "cfg.yaml").write_text(CONFIG)
    render_dataset(load_render_config(str(root / "cfg.yaml")), root / "out", progress=False)
    return root / "out"


def test_crops_at_1_5x_align(fractional_data, tmp_path):
    seq = fractional_data / "q15"
    meta = fmt.read_meta(seq)
    ds = WindowDataset(seq, window=2, crop=(16, 12), cache_dir=tmp_path / "cache", progress=False, seed=3)
    full_lr = fmt.read_buffer(seq, meta, "lr", "color", 0)
    full_hr = fmt.read_buffer(seq, meta, "hr", "reference", 0)
    offsets = set()
    for epoch in range(6):
        ds.set_epoch(epoch)
        crop = ds.crop_for(0)
        assert crop.x % 2 == 0 and crop.y % 2 == 0  # LR offsets on the grid that lands on whole HR pixels
        hr = hr_crop(crop, meta)
        assert hr == Crop(crop.x * 3 // 2, crop.y * 3 // 2, 24, 18)
        item = ds[0]
        assert item["color"].shape == (2, 3, 12, 16) and item["reference"].shape == (2, 3, 18, 24)
        np.testing.assert_allclose(item["color"][0].numpy().transpose(1, 2, 0),
                                   full_lr[crop.y:crop.y + 12, crop.x:crop.x + 16], atol=3e-4)
        np.testing.assert_allclose(item["reference"][0].numpy().transpose(1, 2, 0),
                                   full_hr[hr.y:hr.y + 18, hr.x:hr.x + 24], atol=3e-4)
        offsets.add((crop.x, crop.y))
    assert len(offsets) > 1


def test_crop_sizes_off_the_ratio_grid_are_refused(fractional_data, tmp_path):
    with pytest.raises(UserError, match="multiple of 2x2 LR pixels"):
        WindowDataset(fractional_data / "q15", window=2, crop=(15, 12), cache_dir=tmp_path, progress=False)
    # 80/47 and 45/26 do not reduce: only whole frames map onto whole HR pixels
    with pytest.raises(UserError, match="multiple of 47x26"):
        WindowDataset(fractional_data / "b17", window=2, crop=(16, 12), cache_dir=tmp_path, progress=False)
    ds = WindowDataset(fractional_data / "b17", window=2, crop=(47, 26), cache_dir=tmp_path, progress=False)
    assert ds[0]["reference"].shape == (2, 3, 45, 80)
    with pytest.raises(UserError, match="not a whole pixel"):
        hr_crop(Crop(1, 0, 16, 12), fmt.read_meta(fractional_data / "q15"))


def test_integer_crops_draw_as_before(fractional_data):
    meta = fmt.read_meta(fractional_data / "q15")
    x2 = fmt.replace_meta(meta, scale=2, hr_size=(96, 56))
    assert hr_crop(Crop(3, 5, 7, 9), x2) == Crop(6, 10, 14, 18)


def _edit(seq, change):
    path = seq / "meta.json"
    meta = json.loads(path.read_text())
    change(meta)
    path.write_text(json.dumps(meta))


@pytest.mark.parametrize("change, message", [
    (lambda m: m.update(scale=0.5), "scale 0.5 is outside"),
    (lambda m: m.update(scale=9.5), "scale 9.5 is outside"),
    (lambda m: m.update(scale=1.6), r"lr_size \(48, 28\) is not round\(hr_size \(72, 42\) / 1.6\)"),
    (lambda m: m.update(lr_size=[48, 27]), r"lr_size \(48, 27\) is not round"),
])
def test_data_check_refuses_bad_fractional_meta(fractional_data, tmp_path, capsys, change, message):
    seq = shutil.copytree(fractional_data / "q15", tmp_path / "q15")
    _edit(seq, change)
    code = main(["data", "check", str(seq)])
    out = capsys.readouterr().out
    assert code != 0
    assert re.search(message, out), out


def test_data_info_shows_the_fractional_scale(fractional_data, capsys):
    assert main(["data", "info", str(fractional_data)]) == 0
    out = capsys.readouterr().out
    assert "1.5" in out and "1.7" in out and "47x26" in out and "80x45" in out


def test_eval_bicubic_and_taau_at_fractional_scales(fractional_data, capsys):
    for seq, scale in (("q15", "1.5"), ("b17", "1.7")):
        code = main(["eval", "none", "--data", str(fractional_data / seq), "--scale", scale, "--no-progress"])
        out = capsys.readouterr().out
        assert code == 0 and "bicubic" in out and "taau" in out


@pytest.mark.parametrize("args, message", [
    (["--scale", "0.5"], "--scale 0.5 is outside"), (["--scale", "1.0"], "--scale 1 is outside"),
    (["--scale", "nan"], "finite"), (["--scale", "9"], "--scale 9 is outside"),
    (["--scale", "2"], "data is x1.5 but --scale is 2"),
    (["--methods", "fsr2"], "the fsr2 baseline takes integer scales only"),
])
def test_eval_refuses_bad_scales_in_one_line(fractional_data, capsys, args, message):
    code = main(["eval", "none", "--data", str(fractional_data / "q15"), "--no-progress", *args])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "\n" not in err


def test_bicubic_resample_is_the_integer_bicubic_at_an_integer_size():
    from mnss_kit.eval.baselines import Bicubic, bicubic_resample
    from mnss_kit.model.taau import bicubic_upsample

    g = torch.Generator().manual_seed(0)
    color, jitter = torch.rand(2, 3, 9, 13, generator=g), torch.rand(2, 2, generator=g) - 0.5
    np.testing.assert_allclose(bicubic_resample(color, jitter, (26, 18)).numpy(),
                               bicubic_upsample(color, jitter, 2).numpy(), atol=2e-6)
    assert torch.equal(Bicubic(2.0).upsample(color, jitter), bicubic_upsample(color, jitter, 2))
    b = Bicubic(1.7)
    b.set_output_size((22, 15))
    assert b.upsample(color, jitter).shape == (2, 3, 15, 22)


def test_integer_families_refuse_fractional_data():
    from mnss_kit.model.family import check_data_scale

    for family, why in (("mnss", "pixel insertion"), ("fusesr", "unshuffle"), ("ntaau", "pixel-shuffled")):
        with pytest.raises(UserError, match=f"x1.5, a fractional scale, and the {family} family takes integer scales only .*{why}"):
            check_data_scale(family, 2, 1.5, "data")
    with pytest.raises(UserError, match="data is x3 but the model is x2"):
        check_data_scale("mnss", 2, 3)
    check_data_scale("mnss", 2, 2)


def test_variants_of_fractional_data_pass_data_check(fractional_data, tmp_path, capsys):
    """``data variant`` rewrites LR inputs only: the engine preset and camera motion work at 1.7x, and
    camera motion from depth and the recorded matrices (the display's view) matches the rendered motion."""
    from mnss_kit.dataset.variants import camera_motion

    src = fractional_data / "b17"
    for apply in (["engine"], ["camera_motion", "motion_noise"]):
        out = tmp_path / "_".join(apply)
        assert main(["data", "variant", str(src), "--out", str(out), "--apply", *apply]) == 0
        assert main(["data", "check", str(out)]) == 0
        meta = fmt.read_meta(out / "b17")
        assert (meta.scale, meta.lr_size, meta.hr_size) == (1.7, (47, 26), (80, 45))
    capsys.readouterr()
    meta = fmt.read_meta(src)
    rendered = fmt.canonical_motion(fmt.read_raw_buffer(src, "lr", "motion", 1), meta, meta.lr_size)
    assert np.abs(rendered).max() > 0.1
    derived = fmt.canonical_motion(camera_motion(src, meta, 1), meta, meta.lr_size)
    assert np.median(np.linalg.norm(derived - rendered, axis=-1)) < 1e-3


def test_nss_round_trip_at_1_7(fractional_data, tmp_path):
    from mnss_kit.dataset.importers.nss import import_nss
    from mnss_kit.dataset.nss_export import export_nss

    export_nss([fractional_data / "b17"], tmp_path / "capture")
    assert (tmp_path / "capture" / "x1_7" / "color" / "0000").is_dir()
    import_nss(tmp_path / "capture", tmp_path / "imported")
    (seq,) = fmt.find_sequences(tmp_path / "imported" / "x1_7")
    meta, src = fmt.read_meta(seq), fmt.read_meta(fractional_data / "b17")
    assert (meta.scale, meta.lr_size, meta.hr_size) == (1.7, (47, 26), (80, 45))
    np.testing.assert_allclose([f.jitter for f in meta.frames], [f.jitter for f in src.frames], atol=1e-12)


def test_data_check_scale_and_family_options(fractional_data, capsys):
    seq = str(fractional_data / "q15")
    assert main(["data", "check", seq, "--quick", "--scale", "1.5"]) == 0
    assert main(["data", "check", seq, "--quick", "--scale", "2"]) == 1
    assert "scale 1.5, but --scale is 2" in capsys.readouterr().out
    for bad in ("0.5", "1.0", "nan", "9"):
        assert main(["data", "check", seq, "--quick", "--scale", bad]) == 2
        err = capsys.readouterr().err.strip()
        assert "--scale" in err and "\n" not in err
    assert main(["data", "check", seq, "--quick", "--family", "mnss"]) == 1
    assert "the mnss family takes integer scales only (its pixel insertion" in capsys.readouterr().out


def test_an_mnss_checkpoint_refuses_fractional_data_in_one_line(fractional_data, tmp_path, capsys):
    from mnss_kit.model import checkpoint
    from mnss_kit.model.families import build_model
    from mnss_kit.model.mnss.config import MNSSConfig

    torch.manual_seed(0)
    model = build_model(MNSSConfig(scale=2, recon_width=4, recon_layers=2, aa_width=4, aa_layers=2))
    ckpt = checkpoint.save(tmp_path / "tiny_x2.pt", model, {"jitter_pattern": "grid"})
    code = main(["eval", str(ckpt), "--data", str(fractional_data / "q15"), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err
    assert "data is x1.5, a fractional scale, and the mnss family takes integer scales only (its pixel insertion" in err
