"""``bundle check`` accepts an exported bundle and names the file or tensor of every planted problem."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import numpy as np
import onnx
import pytest
from onnx import numpy_helper

from mnss_kit.cli import main
from mnss_kit.errors import UserError
from mnss_kit.export.check import check_bundle
from mnss_kit.export.manifest import FORMAT_VERSION, NewerFormatError, load_schema
from mnss_kit.fileio import sha256_file


def edit_manifest(bundle: Path, change) -> None:
    path = bundle / "manifest.json"
    manifest = json.loads(path.read_text())
    change(manifest)
    path.write_text(json.dumps(manifest, indent=2))


def rehash(bundle: Path, name: str) -> None:
    """Record ``name``'s new size and hash, so only the deeper checks can notice the change."""
    path = bundle / name

    def update(m):
        m["files"][name] = {"bytes": path.stat().st_size, "sha256": sha256_file(path)}

    edit_manifest(bundle, update)


def assert_one_problem_naming(problems: list[str], *words: str) -> None:
    assert problems, "the planted problem was not found"
    assert all("\n" not in p for p in problems)
    assert any(all(w in p for w in words) for p in problems), problems


def test_exported_bundle_passes_and_matches_schema(bundle):
    assert check_bundle(bundle) == []
    manifest = json.loads((bundle / "manifest.json").read_text())
    jsonschema.Draft202012Validator(load_schema()).validate(manifest)
    assert manifest["format_version"] == FORMAT_VERSION
    listed = set(manifest["files"])
    on_disk = {p.relative_to(bundle).as_posix() for p in bundle.rglob("*") if p.is_file()} - {"manifest.json"}
    assert listed == on_disk
    assert {"npu.tflite", "npu_qdq.onnx", "gpu_weights.bin"} <= listed
    assert all(e["file"] in listed for e in manifest["gpu"]["passes"])


def test_cli_check_ok_and_failing(bundle_copy, capsys):
    assert main(["bundle", "check", str(bundle_copy)]) == 0
    weights = bundle_copy / "gpu_weights.bin"
    data = weights.read_bytes()
    weights.write_bytes(bytes([data[0] ^ 1]) + data[1:])
    assert main(["bundle", "check", str(bundle_copy)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("gpu_weights.bin: SHA-256 differs")


def test_changed_file_is_caught_by_its_hash(bundle_copy):
    path = bundle_copy / "golden" / "frame_001" / "npu_output.bin"
    data = bytearray(path.read_bytes())
    data[10] ^= 1
    path.write_bytes(bytes(data))
    assert check_bundle(bundle_copy) == ["golden/frame_001/npu_output.bin: SHA-256 differs from manifest.json (file changed or corrupt)"]


def test_missing_truncated_and_unlisted_files(bundle_copy):
    (bundle_copy / "shaders" / "warp_pass.comp").unlink()
    tflite = bundle_copy / "npu.tflite"
    tflite.write_bytes(tflite.read_bytes()[:100])
    (bundle_copy / "notes.txt").write_text("hello")
    problems = check_bundle(bundle_copy)
    assert_one_problem_naming(problems, "shaders/warp_pass.comp", "missing")
    assert_one_problem_naming(problems, "npu.tflite", "bytes")
    assert_one_problem_naming(problems, "notes.txt", "not listed")


def test_corrupt_tflite_with_matching_hash_is_named(bundle_copy):
    tflite = bundle_copy / "npu.tflite"
    tflite.write_bytes(tflite.read_bytes()[:64])
    rehash(bundle_copy, "npu.tflite")
    problems = check_bundle(bundle_copy)
    assert_one_problem_naming(problems, "npu.tflite")


def test_newer_format_version_is_refused(bundle_copy, capsys):
    edit_manifest(bundle_copy, lambda m: m.update(format_version=FORMAT_VERSION + 1))
    with pytest.raises(NewerFormatError, match="newer than this mnss-kit reads"):
        check_bundle(bundle_copy)
    assert main(["bundle", "check", str(bundle_copy)]) == 2
    assert "upgrade mnss-kit" in capsys.readouterr().err


def test_not_a_bundle(tmp_path):
    with pytest.raises(UserError, match="manifest.json: missing"):
        check_bundle(tmp_path)
    (tmp_path / "manifest.json").write_text("{not json")
    with pytest.raises(UserError, match="not valid JSON"):
        check_bundle(tmp_path)


def test_schema_violation_names_the_path(bundle_copy):
    edit_manifest(bundle_copy, lambda m: m["npu"].pop("tensors"))
    edit_manifest(bundle_copy, lambda m: m["jitter"]["sequence"][0].update(offset=[0.75, 0.0]))
    problems = check_bundle(bundle_copy)
    assert_one_problem_naming(problems, "schema", "'npu'", "tensors")
    assert_one_problem_naming(problems, "schema", "jitter/sequence/0/offset/0")


def test_tensor_shape_mismatch_names_the_tensor(bundle_copy):
    def change(m):
        t = next(t for t in m["npu"]["tensors"] if t["name"] == "body_0")
        t["shape"] = [1, 7, 7, t["shape"][3]]

    edit_manifest(bundle_copy, change)
    assert_one_problem_naming(check_bundle(bundle_copy), "npu.tflite", "'body_0'", "shape")


def test_quantization_mismatch_in_the_manifest(bundle_copy):
    def change(m):
        m["npu"]["tensors"][0]["zero_point"] += 1
        m["boundary"][0]["zero_point"] += 1

    edit_manifest(bundle_copy, change)
    problems = check_bundle(bundle_copy)
    name = json.loads((bundle_copy / "manifest.json").read_text())["npu"]["tensors"][0]["name"]
    assert_one_problem_naming(problems, "npu.tflite", f"'{name}'", "quantization")
    assert_one_problem_naming(problems, "boundary tensor", "texture_remap")


def test_onnx_quantization_differing_from_tflite(bundle_copy):
    path = bundle_copy / "npu_qdq.onnx"
    model = onnx.load(path)
    init = next(i for i in model.graph.initializer if i.name == "body_2.scale")
    init.CopyFrom(numpy_helper.from_array(numpy_helper.to_array(init) * np.float32(1.01), "body_2.scale"))
    onnx.save(model, path)
    rehash(bundle_copy, "npu_qdq.onnx")
    assert_one_problem_naming(check_bundle(bundle_copy), "npu_qdq.onnx", "'body_2'", "differs from npu.tflite")


def test_weight_block_and_golden_array_bounds(bundle_copy):
    def change(m):
        m["gpu"]["weights"]["blocks"][-1]["offset"] += 4096
        m["golden"]["frames"][0]["arrays"]["display"]["shape"] = [2, 2, 3]

    edit_manifest(bundle_copy, change)
    problems = check_bundle(bundle_copy)
    assert_one_problem_naming(problems, "gpu_weights.bin", "weight block", "past the end")
    assert_one_problem_naming(problems, "golden/frame_000/display.bin", "bytes")
    assert_one_problem_naming(problems, "golden/frame_000/display.bin", "the bundle's sizes need [48, 64, 3]")


def test_schedule_references_are_checked(bundle_copy):
    def change(m):
        step = next(s for s in m["schedule"]["steps"] if s["kind"] == "gpu" and s["pass"] == "conv3x3_pass")
        step["bind"]["weights"] = "weights:missing"
        step["bind"].pop("residual")
        unpack = next(s for s in m["schedule"]["steps"] if s.get("pass") == "unpack_history_pass")
        unpack["bind"]["display"] = "rectified"  # rgba16f where the image unit is rgba8

    edit_manifest(bundle_copy, change)
    problems = check_bundle(bundle_copy)
    assert_one_problem_naming(problems, "conv3x3_pass", "weights:missing", "no such weight block")
    assert_one_problem_naming(problems, "conv3x3_pass", "nothing bound to residual")
    assert_one_problem_naming(problems, "unpack_history_pass", "'display' -> 'rectified'", "declared rgba8")


def test_a_step_without_a_uniform_its_pass_takes_is_named(bundle_copy):
    """A bundle written before a pass gained a uniform (or edited by hand) is refused by name,
    not run with the value missing."""
    def change(m):
        step = next(s for s in m["schedule"]["steps"] if s["kind"] == "gpu" and s["pass"] == "conv3x3_pass")
        step["uniforms"].pop(sorted(step["uniforms"])[0])

    edit_manifest(bundle_copy, change)
    assert_one_problem_naming(check_bundle(bundle_copy), "conv3x3_pass", "no value for", "export it again")
