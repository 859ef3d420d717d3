"""The dump compare tool: per-tensor LSB statistics, execution order, the first diverging tensor, device formats."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mnss_kit.emulate.compare import compare_paths, format_report
from mnss_kit.emulate.dump import DumpWriter, entry_for, read_dump
from mnss_kit.errors import UserError

Q_IN = (1.0 / 255.0, -128)
Q_MID = (0.05, 3)


def frames(count=3, seed=0):
    """Per frame: arrays in execution order and their entries (an image, an int8 tensor, a display)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        arrays = {
            "color": rng.random((4, 6, 3), dtype=np.float32),
            "npu_in": rng.integers(-128, 128, (1, 8, 12, 3)).astype(np.int8),
            "conv": rng.integers(-128, 128, (1, 4, 6, 16)).astype(np.int8),
            "display": rng.integers(0, 256, (8, 12, 3)).astype(np.uint8),
        }
        entries = {"color": entry_for("color", arrays["color"], stage="input"),
                   "npu_in": entry_for("npu_in", arrays["npu_in"], Q_IN, "npu"),
                   "conv": entry_for("conv", arrays["conv"], Q_MID, "npu"),
                   "display": entry_for("display", arrays["display"], stage="gpu")}
        out.append((arrays, entries))
    return out


def write(path, frame_list):
    writer = DumpWriter(path, {"producer": "test"})
    for i, (arrays, entries) in enumerate(frame_list):
        writer.write_frame(i, arrays, entries)
    return path


def test_identical_dumps_report_no_difference(tmp_path):
    data = frames()
    result, report = compare_paths(write(tmp_path / "a", data), write(tmp_path / "b", data))
    assert result.first_diverging is None
    assert report["order"] == ["color", "npu_in", "conv", "display"]
    for stats in report["tensors"].values():
        assert stats["mismatch_fraction"] == 0.0 and stats["psnr"] is None
    assert report["tensors"]["conv"]["max_lsb"] == 0 and report["tensors"]["color"]["max_lsb"] is None
    assert "no differences" in format_report(result)


def test_lsb_statistics_and_first_divergence(tmp_path):
    a = frames()
    b = [({k: v.copy() for k, v in arrays.items()}, entries) for arrays, entries in a]
    conv = b[1][0]["conv"]  # frame 1: two values of 'conv' off, one by 3 LSB
    conv.flat[5] = np.int8(np.clip(int(conv.flat[5]) + 3 if conv.flat[5] < 120 else int(conv.flat[5]) - 3, -128, 127))
    conv.flat[9] = np.int8(int(conv.flat[9]) + 1 if conv.flat[9] < 127 else int(conv.flat[9]) - 1)
    b[2][0]["display"][0, 0, 0] ^= 1  # frame 2: the display
    b[2][0]["npu_in"][0, 0, 0, 0] ^= 1  # frame 2: an earlier tensor, but a later frame
    result, report = compare_paths(write(tmp_path / "a", a), write(tmp_path / "b", b))
    stats = report["tensors"]["conv"]
    assert stats["max_lsb"] == 3 and stats["first_frame"] == 1
    assert stats["mismatch_fraction"] == pytest.approx(2 / (3 * conv.size))
    expected_psnr = 10 * np.log10(255.0**2 / ((9 + 1) / (3 * conv.size)))
    assert stats["psnr"] == pytest.approx(expected_psnr)
    assert report["first_diverging"] == {"tensor": "conv", "frame": 1}
    assert report["tensors"]["display"]["max_lsb"] == 1 and report["tensors"]["npu_in"]["first_frame"] == 2
    text = format_report(result)
    assert ">> conv" in text and "first diverging tensor: 'conv' in frame 1" in text


def test_quantized_tensors_with_other_params_compare_real_values(tmp_path):
    a = frames(1)
    arrays, entries = a[0]
    real = (arrays["conv"].astype(np.float64) - Q_MID[1]) * np.float32(Q_MID[0])
    other = {**arrays, "conv": arrays["conv"].astype(np.float32) * 0 + real.astype(np.float32)}
    b_entries = {**entries, "conv": entry_for("conv", other["conv"], None, "npu")}
    _, report = compare_paths(write(tmp_path / "a", a), write(tmp_path / "b", [(other, b_entries)]))
    stats = report["tensors"]["conv"]
    assert stats["compared"] == "real" and stats["max_lsb"] < 1e-4


def test_device_style_dump_with_raw_bin_and_npy_files(tmp_path):
    """What an Android self-test writes: raw little-endian .bin files (and .npy), described in index.json."""
    a = frames(2)
    write(tmp_path / "emulator", a)
    device = tmp_path / "device"
    frames_json = []
    for i, (arrays, _) in enumerate(a):
        folder = device / f"frame_{i:05d}"
        folder.mkdir(parents=True)
        files = {}
        for name, array in arrays.items():
            if name == "color":
                np.save(folder / "color.npy", array)
                files[name] = f"frame_{i:05d}/color.npy"
            else:
                (folder / f"{name}.bin").write_bytes(array.astype(array.dtype.newbyteorder("<")).tobytes())
                files[name] = f"frame_{i:05d}/{name}.bin"
        frames_json.append({"index": i, "files": files})
    tensors = [{"name": "npu_in", "dtype": "int8", "shape": [1, 8, 12, 3], "scale": Q_IN[0], "zero_point": Q_IN[1]},
               {"name": "conv", "dtype": "int8", "shape": [1, 4, 6, 16], "scale": Q_MID[0], "zero_point": Q_MID[1]},
               {"name": "display", "dtype": "uint8", "shape": [8, 12, 3]}]
    (device / "index.json").write_text(json.dumps({"format": "mnss-kit-dump", "version": 1, "tensors": tensors, "frames": frames_json}))
    result, report = compare_paths(tmp_path / "emulator", device)
    assert result.first_diverging is None and report["order"] == ["color", "npu_in", "conv", "display"]


def test_per_file_entry_overrides(tmp_path):
    root = tmp_path / "d"
    root.mkdir()
    x = np.arange(12, dtype=np.int8).reshape(3, 4)
    (root / "x.bin").write_bytes(x.tobytes())
    (root / "index.json").write_text(json.dumps({"format": "mnss-kit-dump", "version": 1, "tensors": [], "frames": [
        {"index": 0, "files": {"x": {"file": "x.bin", "dtype": "int8", "shape": [3, 4], "scale": 0.5, "zero_point": 1}}}]}))
    array, entry = read_dump(root).frame(0)["x"]
    assert np.array_equal(array, x) and entry.scale == 0.5 and entry.zero_point == 1


@pytest.mark.parametrize("problem, message", [
    ("no_index", "index.json: missing"),
    ("bad_json", "not valid JSON"),
    ("wrong_format", "not a tensor dump"),
    ("short_bin", "bytes"),
    ("missing_file", "missing"),
    ("no_shape", "needs dtype and shape"),
])
def test_bad_dumps_are_user_errors(tmp_path, problem, message):
    good = write(tmp_path / "good", frames(1))
    root = tmp_path / "bad"
    root.mkdir()
    index = {"format": "mnss-kit-dump", "version": 1,
             "tensors": [{"name": "t", "dtype": "int8", "shape": [4]}], "frames": [{"index": 0, "files": {"t": "t.bin"}}]}
    (root / "t.bin").write_bytes(bytes(4))
    if problem == "bad_json":
        (root / "index.json").write_text("{")
    elif problem == "wrong_format":
        (root / "index.json").write_text(json.dumps({**index, "format": "other"}))
    elif problem == "short_bin":
        (root / "t.bin").write_bytes(bytes(3))
    elif problem == "missing_file":
        (root / "t.bin").unlink()
    elif problem == "no_shape":
        index["tensors"] = [{"name": "t", "dtype": "int8"}]
    if problem not in ("no_index", "bad_json", "wrong_format"):
        (root / "index.json").write_text(json.dumps(index))
    with pytest.raises(UserError, match=message):
        compare_paths(good, root)


def test_shape_mismatch_and_no_common_frame(tmp_path):
    a = frames(1)
    arrays, entries = a[0]
    b = [({**arrays, "conv": arrays["conv"][..., :8]}, entries)]
    with pytest.raises(UserError, match="tensor 'conv' frame 0: shape"):
        compare_paths(write(tmp_path / "a", a), write(tmp_path / "b", b))
    writer = DumpWriter(tmp_path / "c")
    writer.write_frame(7, arrays, entries)
    with pytest.raises(UserError, match="share no frame"):
        compare_paths(tmp_path / "a", tmp_path / "c")


def test_a_tensor_one_frame_lacks_is_a_difference(tmp_path):
    """Both dumps hold 'conv', frame 1 of the second does not: a difference, named with its frame."""
    a = frames()
    b = [(dict(arrays), entries) for arrays, entries in a]
    del b[1][0]["conv"]
    result, report = compare_paths(write(tmp_path / "a", a), write(tmp_path / "b", b))
    assert result.first_diverging is None and result.differs()
    assert report["missing"] == [{"tensor": "conv", "frame": 1, "missing_from": "b"}]
    assert report["only_in_a"] == [] and "tensor 'conv' is missing from frame 1 of the second dump" in format_report(result)
    assert "no differences" not in format_report(result)


def test_a_tensor_only_one_dump_holds_is_no_difference(tmp_path):
    """A device dump holds what the device reads back: a tensor it never has is listed, not a difference."""
    a = frames()
    b = [({k: v for k, v in arrays.items() if k != "conv"}, entries) for arrays, entries in a]
    result, report = compare_paths(write(tmp_path / "a", a), write(tmp_path / "b", b))
    assert not result.differs() and report["only_in_a"] == ["conv"] and report["missing"] == []
