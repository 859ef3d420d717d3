"""A 30-frame NSS capture written from the toolkit's own renderer (a camera cut, linear HDR) imports to the
renderer's native dataset of the same frames, and fine-tunes from the shipped model."""

import numpy as np
import pytest

from mnss_kit import cli
from mnss_kit.dataset.format import read_buffer, read_meta
from mnss_kit.dataset.exr import read_exr
from mnss_kit.dataset.nss_export import write_nss_sequence

CAMERA = """
keyframes:
  - {time: 0.0, position: [-10, 14, 12], look_at: [-9, 0, 0]}
  - {time: 0.5, position: [-6, 14, 11], look_at: [-4, 0, 0]}
  - {time: 0.52, position: [14, 13, -12], look_at: [14, 0, -24], cut: true}
  - {time: 1.2, position: [16, 12, -10], look_at: [13, 0, -22]}
"""
CONFIG = """
version: 1
defaults: {lr_size: [32, 18], scale: 2, jitter: grid, hr_samples: 4, fps: 30, frames: 30}
sequences:
  - {name: arena, scene: arena, seed: 11, camera: cam.yaml, exposure: 1.5}
"""
HALF_ULP = 2.0**-11  # relative rounding to the nearest half float


@pytest.mark.slow
def test_rendered_nss_capture_imports_to_the_native_dataset(tmp_path, capsys):
    (tmp_path / "cam.yaml").write_text(CAMERA)
    (tmp_path / "render.yaml").write_text(CONFIG)
    assert cli.main(["render", str(tmp_path / "render.yaml"), "--out", str(tmp_path / "native"), "--no-progress"]) == 0
    native = tmp_path / "native" / "arena"
    write_nss_sequence(native, tmp_path / "nss")
    assert cli.main(["data", "import", "nss", str(tmp_path / "nss"), "--out", str(tmp_path / "imported")]) == 0, capsys.readouterr().err
    imported = tmp_path / "imported" / "x2" / "0000"
    n_meta, i_meta = read_meta(native), read_meta(imported)
    assert i_meta.frame_count == n_meta.frame_count == 30
    resets = [f.reset for f in n_meta.frames]
    assert sum(resets) == 2 and [f.reset for f in i_meta.frames] == resets  # frame 0 and the cut
    assert [f.jitter for f in i_meta.frames] == [f.jitter for f in n_meta.frames]
    assert i_meta.exposure == n_meta.exposure == 1.5 and i_meta.color_space == "linear_hdr"
    for t in range(30):
        for res, buffer in (("lr", "color"), ("hr", "reference"), ("lr", "depth")):
            # half colour and float depth are copied exactly; the conventions recorded give the same canonical values
            np.testing.assert_array_equal(read_buffer(imported, i_meta, res, buffer, t), read_buffer(native, n_meta, res, buffer, t))
        for res, folder in (("lr", tmp_path / "nss" / "x2" / "motion"), ("hr", tmp_path / "nss" / "motion_gt")):
            size = np.array(n_meta.lr_size if res == "lr" else n_meta.hr_size, np.float32)
            got = read_buffer(imported, i_meta, res, "motion", t)
            # the import reproduces the capture's UV motion within 1e-3 px ...
            stored = read_exr(folder / "0000" / f"{t:04d}.exr", ("R", "G")) * size
            assert np.abs(got - stored).max() < 1e-3
            # ... and the capture holds the renderer's motion to the half-float rounding of the UV value
            want = read_buffer(native, n_meta, res, "motion", t)
            # (relative 2^-11; near zero, half's subnormal spacing 2^-24 of a UV unit)
            assert np.all(np.abs(got - want) <= np.abs(want) * HALF_ULP + size * 2.0**-24)
    run = tmp_path / "run"
    experiment = tmp_path / "tune.yaml"
    experiment.write_text(f"""
schema: 1
model: {{family: mnss, scale: 2, history: output, recon_resolution: lr, recon_width: 32, recon_layers: 4, aa_width: 16,
        aa_layers: 3, aa_history_at_samples: true, inpaint_activation: sigmoid, weight_upsample: bilinear, enhance: false}}
train: {{train_data: {tmp_path / 'imported' / 'x2'}, window: 3, burn_in: 1, batch_size: 1, crop: 12, epochs: 1,
        steps_per_epoch: 2, gt_history_epochs: 0, threads: 1, val_every: 0, cache_dir: {tmp_path / 'cache'}}}
""")
    assert cli.main(["train", str(experiment), "--out", str(run), "--init", "mnss_x2", "--no-progress"]) == 0
    assert (run / "model.pt").is_file()
