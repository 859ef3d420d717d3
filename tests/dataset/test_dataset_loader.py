"""Training windows and evaluation frames: contents, crops, resets, determinism."""

import json
import shutil

import numpy as np
import pytest
import torch

from mnss_kit.dataset.format import read_buffer, read_meta
from mnss_kit.dataset.loader import WindowDataset, eval_sequences
from mnss_kit.errors import UserError
from mnss_kit.ops.resample import avgpool

# what the synthetic_dataset fixture (tests/conftest.py) holds
S = 2
SYNTHETIC_FRAMES = 8
SYNTHETIC_LR_SIZE = (32, 24)
SYNTHETIC_CUT_AT = 5


def hwc(tensor: torch.Tensor) -> np.ndarray:
    return tensor.numpy().transpose(1, 2, 0)


def find_offsets(full: np.ndarray, crop: np.ndarray) -> list[tuple[int, int]]:
    """Every (x, y) where ``crop`` (C, h, w) equals a window of ``full`` (C, H, W)."""
    _, h, w = crop.shape
    return [
        (x, y)
        for y in range(full.shape[1] - h + 1)
        for x in range(full.shape[2] - w + 1)
        if np.array_equal(full[:, y : y + h, x : x + w], crop)
    ]


def test_window_shapes_dtypes_and_count(synthetic_dataset):
    ds = WindowDataset(synthetic_dataset, 3, crop=(16, 12), hr_buffers=("depth", "motion"), cache=False)
    # two sequences of 8 frames, windows never span them: 2 * (8 - 3 + 1)
    assert len(ds) == 2 * (SYNTHETIC_FRAMES - 3 + 1)
    w = ds[0]
    expected = {
        "color": (3, 3, 12, 16), "depth": (3, 1, 12, 16), "motion": (3, 2, 12, 16), "jitter": (3, 2), "reset": (3,),
        "reference": (3, 3, 24, 32), "hr_depth": (3, 1, 24, 32), "hr_motion": (3, 2, 24, 32),
    }
    assert {k: tuple(v.shape) for k, v in w.items()} == expected
    assert all(v.dtype == torch.float32 for v in w.values())


def test_windows_hold_consecutive_frames_of_one_sequence(synthetic_dataset):
    ds = WindowDataset(synthetic_dataset, 4, cache=False)
    for index in range(len(ds)):
        name, start = ds.window_info(index)
        seq_dir = synthetic_dataset / name
        meta = read_meta(seq_dir)
        w = ds[index]
        assert start + 4 <= meta.frame_count
        for t in range(4):
            frame = meta.frames[start + t]
            np.testing.assert_array_equal(hwc(w["color"][t]), read_buffer(seq_dir, meta, "lr", "color", frame.index))
            np.testing.assert_array_equal(hwc(w["motion"][t]), read_buffer(seq_dir, meta, "lr", "motion", frame.index))
            np.testing.assert_array_equal(hwc(w["reference"][t]), read_buffer(seq_dir, meta, "hr", "reference", frame.index))
            np.testing.assert_allclose(w["jitter"][t].numpy(), frame.jitter, atol=1e-7)


def test_crops_cover_the_same_screen_area_at_both_resolutions(synthetic_dataset):
    cropped = WindowDataset(synthetic_dataset, 2, crop=(16, 12), seed=5, cache=False)
    full = WindowDataset(synthetic_dataset, 2, cache=False)
    aligned_err, unscaled_err = [], []
    for index in range(len(cropped)):
        crop, w, f = cropped.crop_for(index), cropped[index], full[index]
        lr_hits = find_offsets(f["color"][0].numpy(), w["color"][0].numpy())
        hr_hits = find_offsets(f["reference"][0].numpy(), w["reference"][0].numpy())
        assert lr_hits == [(crop.x, crop.y)]
        assert hr_hits == [(S * crop.x, S * crop.y)]  # unique, and a multiple of the scale
        # the box-filtered reference pooled to LR resembles the LR colour there, and much less at
        # the offset a crop that forgot the scale would take
        lr = hwc(w["color"][0])
        aligned_err.append(np.abs(avgpool(hwc(w["reference"][0]), S) - lr).mean())
        wrong = hwc(f["reference"][0])[crop.y : crop.y + 12 * S, crop.x : crop.x + 16 * S]
        unscaled_err.append(np.abs(avgpool(wrong, S) - lr).mean())
    assert max(aligned_err) < 0.075
    assert np.median(aligned_err) < 0.7 * np.median(unscaled_err)


def test_crops_are_deterministic_per_seed_and_epoch(synthetic_dataset):
    a = WindowDataset(synthetic_dataset, 2, crop=(8, 8), seed=11, cache=False)
    b = WindowDataset(synthetic_dataset, 2, crop=(8, 8), seed=11, cache=False)
    c = WindowDataset(synthetic_dataset, 2, crop=(8, 8), seed=12, cache=False)
    crops = [a.crop_for(i) for i in range(len(a))]
    assert crops == [b.crop_for(i) for i in range(len(b))]
    assert crops != [c.crop_for(i) for i in range(len(c))]
    for key, value in a[3].items():
        assert torch.equal(value, b[3][key]), key
    b.set_epoch(1)
    assert crops != [b.crop_for(i) for i in range(len(b))]
    # read order does not matter (workers load windows in any order)
    assert [a.crop_for(i) for i in reversed(range(len(a)))] == crops[::-1]


def test_resets_keep_the_cut_and_mark_window_starts(synthetic_dataset):
    on = WindowDataset(synthetic_dataset, 4, cache=False, window_starts_reset=True)
    off = WindowDataset(synthetic_dataset, 4, cache=False, window_starts_reset=False)
    for index in range(len(on)):
        name, start = on.window_info(index)
        meta = read_meta(synthetic_dataset / name)
        recorded = np.array([meta.frames[start + t].reset for t in range(4)], dtype=np.float32)
        expected_off = recorded.copy()
        expected_off[0] = 1.0 if start == 0 else recorded[0]
        expected_on = recorded.copy()
        expected_on[0] = 1.0
        np.testing.assert_array_equal(off[index]["reset"].numpy(), expected_off)
        np.testing.assert_array_equal(on[index]["reset"].numpy(), expected_on)
    # a window over the cut carries it inside the window
    index = next(i for i in range(len(off)) if off.window_info(i) == ("pan_cut", SYNTHETIC_CUT_AT - 2))
    np.testing.assert_array_equal(off[index]["reset"].numpy(), [0, 0, 1, 0])


def test_cached_windows_match_exr_windows(synthetic_dataset, tmp_path):
    exr = WindowDataset(synthetic_dataset, 3, crop=(16, 12), lr_buffers=(), hr_buffers=("motion",), seed=2, cache=False)
    cached = WindowDataset(synthetic_dataset, 3, crop=(16, 12), hr_buffers=("motion",), seed=2, cache_dir=tmp_path)
    for index in (0, len(exr) - 1):
        a, b = exr[index], cached[index]
        for key in ("depth", "motion", "hr_motion", "jitter", "reset"):
            assert torch.equal(a[key], b[key]), key  # float32 in the cache: exact
        for key in ("color", "reference"):
            assert torch.allclose(a[key], b[key], atol=2.5e-4), key  # float16 display values


def test_dataloader_workers_batch_windows(synthetic_dataset, tmp_path):
    ds = WindowDataset(synthetic_dataset, 2, crop=(8, 8), seed=1, cache_dir=tmp_path)
    loader = torch.utils.data.DataLoader(ds, batch_size=3, num_workers=1, shuffle=False)
    batch = next(iter(loader))
    assert tuple(batch["color"].shape) == (3, 2, 3, 8, 8)
    assert tuple(batch["reference"].shape) == (3, 2, 3, 16, 16)
    assert torch.equal(batch["color"][1], ds[1]["color"])


def test_eval_sequences_yield_full_frames_in_order(synthetic_dataset):
    seqs = eval_sequences(synthetic_dataset, hr_buffers=("depth",))
    assert [s.name for s in seqs] == ["pan", "pan_cut"]
    frames = list(seqs[1])
    assert len(frames) == SYNTHETIC_FRAMES
    lw, lh = SYNTHETIC_LR_SIZE
    assert tuple(frames[0]["color"].shape) == (1, 3, lh, lw)
    assert tuple(frames[0]["reference"].shape) == (1, 3, lh * S, lw * S)
    assert tuple(frames[0]["hr_depth"].shape) == (1, 1, lh * S, lw * S)
    assert [float(f["reset"][0]) for f in frames] == [1.0 if t in (0, SYNTHETIC_CUT_AT) else 0.0 for t in range(SYNTHETIC_FRAMES)]
    meta = read_meta(synthetic_dataset / "pan_cut")
    np.testing.assert_array_equal(hwc(frames[6]["color"][0]), read_buffer(synthetic_dataset / "pan_cut", meta, "lr", "color", 6))


def test_user_mistakes_are_one_line_errors(synthetic_dataset):
    with pytest.raises(UserError, match="does not fit"):
        WindowDataset(synthetic_dataset, 2, crop=(64, 8), cache=False)
    with pytest.raises(UserError, match="hr/albedo is not in this sequence"):
        WindowDataset(synthetic_dataset, 2, hr_buffers=("albedo",), cache=False)
    with pytest.raises(UserError, match="always loaded"):
        WindowDataset(synthetic_dataset, 2, lr_buffers=("color",), cache=False)
    with pytest.raises(UserError, match="frames a window needs"):
        WindowDataset(synthetic_dataset, SYNTHETIC_FRAMES + 1, cache=False)


def test_first_frame_of_a_sequence_is_a_reset_even_if_not_recorded(synthetic_dataset, tmp_path):
    data = shutil.copytree(synthetic_dataset / "pan", tmp_path / "pan")
    meta = json.loads((data / "meta.json").read_text())
    meta["frames"][0]["reset"] = False
    (data / "meta.json").write_text(json.dumps(meta))
    ds = WindowDataset(data, 3, cache=False, window_starts_reset=False)
    assert ds.window_info(0) == ("pan", 0)
    np.testing.assert_array_equal(ds[0]["reset"].numpy(), [1, 0, 0])
    np.testing.assert_array_equal(ds[1]["reset"].numpy(), [0, 0, 0])
    assert float(next(iter(eval_sequences(data)[0]))["reset"][0]) == 1.0
