"""``mnss-kit export --sequence DIR --frames N``: the bundle carries N recorded frames of every
input resource, compressed; ``bundle check`` validates them."""

from __future__ import annotations

import json
import zlib

import numpy as np
import pytest
from recorded_sequence import SEQUENCE_FRAMES
from test_bundle_check import assert_one_problem_naming, edit_manifest, rehash

from mnss_kit.cli import main
from mnss_kit.dataset.loader import eval_sequences
from mnss_kit.export.check import check_bundle
from mnss_kit.export.sequence import read_sequence_array


def test_sequence_holds_every_input_of_the_dataset_frames(bundle, synthetic_dataset):
    manifest = json.loads((bundle / "manifest.json").read_text())
    sequence = manifest["sequence"]
    inputs = {r["name"]: r for r in manifest["resources"] if r["role"] == "input"}
    assert sequence["frame_count"] == SEQUENCE_FRAMES and set(sequence["arrays"]) == set(inputs)
    seq = eval_sequences(synthetic_dataset, progress=False)[0]
    assert seq.name in sequence["source"]
    dataset = list(seq)[:SEQUENCE_FRAMES]
    for name, entry in sequence["arrays"].items():
        w, h = inputs[name]["size"]
        data = read_sequence_array(bundle, entry)
        assert data.shape == (SEQUENCE_FRAMES, h, w, inputs[name]["channels"])
        expected = np.stack([f[name][0].permute(1, 2, 0).numpy() for f in dataset]).astype(entry["dtype"])
        np.testing.assert_array_equal(data, expected)
        assert manifest["files"][entry["file"]]["bytes"] < entry["bytes"]  # compressed
    for t, (entry, frame) in enumerate(zip(sequence["frames"], dataset)):
        assert entry["index"] == t and entry["reset"] == (t == 0 or float(frame["reset"][0]) > 0.5)
        np.testing.assert_array_equal(np.float32(entry["jitter"]), frame["jitter"][0].numpy().astype(np.float32))


def test_truncated_stream_is_named(bundle_copy):
    entry = json.loads((bundle_copy / "manifest.json").read_text())["sequence"]["arrays"]["color"]
    path = bundle_copy / entry["file"]
    path.write_bytes(path.read_bytes()[:-20])
    rehash(bundle_copy, entry["file"])
    assert_one_problem_naming(check_bundle(bundle_copy), entry["file"], "decompress")


def test_stream_of_the_wrong_size_is_named(bundle_copy):
    entry = json.loads((bundle_copy / "manifest.json").read_text())["sequence"]["arrays"]["depth"]
    path = bundle_copy / entry["file"]
    path.write_bytes(zlib.compress(zlib.decompress(path.read_bytes())[:-4]))
    rehash(bundle_copy, entry["file"])
    assert_one_problem_naming(check_bundle(bundle_copy), entry["file"], "bytes uncompressed")


def test_missing_input_and_wrong_shape_are_named(bundle_copy):
    def change(m):
        del m["sequence"]["arrays"]["motion"]
        m["sequence"]["arrays"]["color"]["shape"][0] += 1

    edit_manifest(bundle_copy, change)
    problems = check_bundle(bundle_copy)
    assert_one_problem_naming(problems, "sequence lacks input resource 'motion'")
    assert_one_problem_naming(problems, "sequence 'color'", "the bundle needs float16")


def test_non_finite_values_are_named(bundle_copy):
    entry = json.loads((bundle_copy / "manifest.json").read_text())["sequence"]["arrays"]["depth"]
    data = read_sequence_array(bundle_copy, entry).copy()
    data.flat[5] = np.nan
    (bundle_copy / entry["file"]).write_bytes(zlib.compress(data.tobytes()))
    rehash(bundle_copy, entry["file"])
    assert_one_problem_naming(check_bundle(bundle_copy), entry["file"], "1 NaN or Inf value")


def test_schema_refuses_an_unknown_compression(bundle_copy):
    edit_manifest(bundle_copy, lambda m: m["sequence"]["arrays"]["color"].update(compression="lz4"))
    assert_one_problem_naming(check_bundle(bundle_copy), "compression")


@pytest.mark.parametrize("frames", [0, 99])
def test_sequence_that_cannot_be_had_is_a_user_error(tiny_ckpt, synthetic_dataset, tmp_path, capsys, frames):
    code = main(["export", str(tiny_ckpt), "--out", str(tmp_path / "b"), "--resolution", "64x48", "--data", str(synthetic_dataset),
                 "--sequence", str(synthetic_dataset), "--frames", str(frames), "--no-progress"])
    assert code == 2
    err = capsys.readouterr().err
    assert ("--frames must be at least 1" in err) if frames == 0 else ("no sequence of at least 99 frames" in err and "32x24" in err)
    assert not (tmp_path / "b").exists()
