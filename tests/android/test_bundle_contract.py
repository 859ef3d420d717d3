"""The Java core on a bundle written by ``mnss-kit export``: it reads every field the schema
requires, verifies hashes as ``bundle check`` does, schedules frames as the manifest says, and
writes self-test dumps that the emulator's compare tool matches against the emulator's own."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from mnss_kit.emulate.compare import compare_dumps
from mnss_kit.emulate.dump import read_dump
from mnss_kit.emulate.run import run_dataset
from mnss_kit.export.check import check_files
from mnss_kit.export.manifest import file_table, load_schema, schema_problems

pytestmark = pytest.mark.slow  # the session's export takes ~10 s


def required_paths(schema: dict, instance, root: dict | None = None, path: str = "") -> set[str]:
    """JSON paths (``"npu/tensors/0/scale"``) of every member ``instance`` holds because ``schema``
    requires it, recursively; array elements of required arrays count as required."""
    root = root or schema
    if "$ref" in schema:
        name = schema["$ref"].split("/")[-1]
        return required_paths(root["$defs"][name], instance, root, path)
    out: set[str] = set()

    def valid(branch):
        return jsonschema.Draft202012Validator({**branch, "$defs": root["$defs"]}).is_valid(instance)

    for key in ("oneOf", "anyOf"):
        for branch in schema.get(key, []):
            if valid(branch):
                out |= required_paths(branch, instance, root, path)
                break
    if "if" in schema:
        chosen = schema.get("then") if valid(schema["if"]) else schema.get("else")
        if chosen:
            out |= required_paths(chosen, instance, root, path)
    join = (lambda k: f"{path}/{k}" if path else str(k))
    if isinstance(instance, dict):
        props = schema.get("properties", {})
        for key in schema.get("required", []):
            if key in instance:
                out.add(join(key))
                out |= required_paths(props.get(key, {}), instance[key], root, join(key))
        extra = schema.get("additionalProperties")
        if isinstance(extra, dict):
            for key, value in instance.items():
                if key not in props:
                    out.add(join(key))
                    out |= required_paths(extra, value, root, join(key))
    elif isinstance(instance, list) and isinstance(schema.get("items"), dict):
        for i, value in enumerate(instance):
            out.add(join(i))
            out |= required_paths(schema["items"], value, root, join(i))
    return out


@pytest.fixture(scope="module")
def manifest(tiny_bundle) -> dict:
    return json.loads((tiny_bundle / "manifest.json").read_text())


def test_java_reads_every_field_the_schema_requires(java_core, tiny_bundle, manifest, tmp_path):
    log = tmp_path / "access.log"
    java_core.tool("read", str(tiny_bundle), str(log))
    read = set(log.read_text().splitlines())
    required = required_paths(load_schema(), manifest)
    assert len(required) > 300  # the walk really went through the bundle
    assert sorted(required - read) == []


def test_java_reading_agrees_with_the_manifest(java_core, tiny_bundle, manifest, tmp_path):
    summary = json.loads(java_core.tool("read", str(tiny_bundle), str(tmp_path / "log")))
    assert summary["schedule_problems"] == []
    assert summary["model"] == manifest["model"]["id"]
    assert (summary["scale"], summary["lr_size"], summary["hr_size"]) == (manifest["scale"], manifest["lr_size"], manifest["hr_size"])
    table = [[np.float32(e["offset"][0]), np.float32(e["offset"][1]), *e["subpixel"]] for e in manifest["jitter"]["sequence"]]
    assert summary["jitter"] == [[float(v) for v in row] for row in table]
    assert summary["stages"] == [[s["name"], s["placement"]] for s in manifest["stages"]]
    assert summary["passes"] == [p["name"] for p in manifest["gpu"]["passes"]]
    for b in manifest["boundary"]:
        tensor, scale, zp, shape, words = summary["boundary"][b["role"]]
        assert (tensor, zp, shape, words) == (b["tensor"], b["zero_point"], b["shape"], b["buffer"]["words"])
        assert np.float32(scale) == np.float32(b["scale"])
    assert summary["files"] == len(manifest["files"])
    assert summary["golden_frames"] == len(manifest["golden"]["frames"])


def expected_schedule(manifest: dict, frames: int, cuts: set[int]) -> list[dict]:
    """The schedule as the manifest's text describes it, written independently of the Java code."""
    physical = {r["name"]: r["name"] for r in manifest["resources"]}
    table = manifest["jitter"]["sequence"]
    out, previous = [], None
    for t in range(frames):
        if t:
            for a, b in (e["swap"] for e in manifest["schedule"]["end_of_frame"]):
                physical[a], physical[b] = physical[b], physical[a]
        reset = t == 0 or t in cuts
        entry = table[t % len(table)]
        prev = entry if t == 0 else previous  # the previous frame's entry, also on a cut
        frame_values = {"offset": entry["offset"], "subpixel": entry["subpixel"], "previous_offset": prev["offset"],
                        "previous_subpixel": prev["subpixel"], "reset": [int(reset)]}
        steps = []
        for step in manifest["schedule"]["steps"]:
            if reset and step.get("skip_on_reset"):
                continue
            if step["kind"] == "npu":
                bind = {k: physical[v] for k, v in {**step["inputs"], **step["outputs"]}.items()}
                uniforms = {}
            else:
                bind = {k: v if v.startswith("weights:") else physical[v] for k, v in step["bind"].items()}
                uniforms = {}
                for name, u in step["uniforms"].items():
                    value = frame_values[u["frame"]] if "frame" in u else u["value"]
                    uniforms[name] = [float(np.float32(v)) if isinstance(v, float) else float(v) for v in np.atleast_1d(value)]
            steps.append({"label": step["label"], "bind": bind, "uniforms": uniforms})
        out.append({"reset": reset, "jitter_index": entry["index"], "steps": steps})
        previous = entry
    return out


def test_java_schedule_follows_the_manifest(java_core, tiny_bundle, manifest):
    frames, cuts = 15, {5}
    plans = json.loads(java_core.tool("schedule", str(tiny_bundle), str(frames), ",".join(map(str, cuts))))
    assert plans == expected_schedule(manifest, frames, cuts)
    labels = [[s["label"] for s in p["steps"]] for p in plans]
    assert "warp" not in labels[0] and "warp" not in labels[5] and "warp" in labels[1]
    assert plans[1]["steps"][0]["bind"]["prev_depth"] != plans[2]["steps"][0]["bind"]["prev_depth"]  # ping-pong


def test_hash_verification_agrees_with_bundle_check(java_core, tiny_bundle, manifest, tmp_path):
    assert java_core.tool("verify", str(tiny_bundle)) == ""
    copy = Path(shutil.copytree(tiny_bundle, tmp_path / "bundle"))
    shader = copy / manifest["gpu"]["passes"][0]["file"]
    shader.write_text(shader.read_text().replace("void main", "void  main", 1))
    (copy / "npu_qdq.onnx").unlink()
    golden = copy / manifest["golden"]["frames"][0]["arrays"]["display"]["file"]
    golden.write_bytes(golden.read_bytes()[:-1])
    (copy / "golden" / "notes.txt").write_text("extra")
    java = java_core.tool("verify", str(copy)).splitlines()
    python = check_files(copy, manifest)
    assert sorted(java) == sorted(python)
    assert len(java) == 4


@pytest.fixture(scope="module")
def emulator_dump(tiny_bundle, manifest, synthetic_dataset, tmp_path_factory) -> Path:
    """The desktop emulator's dump of the golden frames' sequence (numpy GPU passes, LiteRT
    reference kernels: the golden frames' own numerics)."""
    from mnss_kit.emulate.frame_loop import Emulator

    match = re.search(r"sequence (\S+?),", manifest["golden"]["source"])
    assert match, f"golden frames do not name their dataset sequence: {manifest['golden']['source']}"
    out = tmp_path_factory.mktemp("emulator") / "out"
    emulator = Emulator(tiny_bundle, npu_profile="tflite-ref", npu_backend="numpy", gpu_backend="numpy")
    run_dataset(emulator, synthetic_dataset / match.group(1), out_dir=out, dump=True, frames=len(manifest["golden"]["frames"]))
    (index,) = out.rglob("index.json")
    return index.parent


@pytest.mark.parametrize("error", [0, 2])
def test_self_test_dump_compares_with_the_emulator_dump(java_core, tiny_bundle, manifest, emulator_dump, tmp_path, error):
    """The Java self-test's dump (golden echo, one NPU output value off by ``error``) against the
    emulator's own dump, through the emulator's compare tool."""
    device = tmp_path / "device_dump"
    report = java_core.tool("selftest", str(tiny_bundle), str(device), str(error))
    assert report.strip().endswith("PASSED" if error == 0 else "FAILED"), report
    assert report.splitlines()[0] == "inputs: " + ",".join(sorted(r["name"] for r in manifest["resources"] if r["role"] == "input"))
    npu_in, npu_out = (b["tensor"] for b in manifest["boundary"])
    dump = read_dump(device)
    assert list(dump.tensors) == [npu_in, npu_out, "display"]
    assert dump.tensors[npu_in].scale == pytest.approx(manifest["boundary"][0]["scale"], rel=1e-7)
    result = compare_dumps(read_dump(emulator_dump), dump).as_json()
    assert result["frames"] == [f["index"] for f in manifest["golden"]["frames"]]
    assert set(result["tensors"]) == {npu_in, npu_out, "display"}
    assert result["tensors"][npu_in]["max_lsb"] == 0
    assert result["tensors"]["display"]["max_lsb"] == 0
    assert result["tensors"][npu_out]["max_lsb"] == error
    assert result["first_diverging"] == (None if error == 0 else {"tensor": npu_out, "frame": 0})


def with_extra_input(bundle: Path, manifest: dict, out: Path, name: str = "hr_albedo") -> dict:
    """A copy of ``bundle`` whose manifest lists one more ``input`` resource (an HR float16 texture
    no MNSS pass reads) with a golden array per frame (and a recorded sequence array), file table and hashes rewritten as export
    writes them; returns the new manifest."""
    copy = Path(shutil.copytree(bundle, out))
    edited = json.loads(json.dumps(manifest))
    width, height = edited["hr_size"]
    edited["resources"].insert(1, {"name": name, "kind": "texture2d", "size": [width, height], "format": "rgba16f",
                                   "channels": 3, "role": "input", "description": "HR albedo G-buffer (test input)"})
    rng = np.random.default_rng(3)
    for frame in edited["golden"]["frames"]:
        file = f"golden/frame_{frame['index']:03d}/{name}.bin"
        (copy / file).write_bytes(rng.random((height, width, 3)).astype("<f2").tobytes())
        frame["arrays"][name] = {"file": file, "dtype": "float16", "shape": [height, width, 3]}
    if "sequence" in edited:  # the recorded sequence carries every input too
        import zlib

        n = edited["sequence"]["frame_count"]
        raw = rng.random((n, height, width, 3)).astype("<f2").tobytes()
        (copy / f"sequence/{name}.zlib").write_bytes(zlib.compress(raw))
        edited["sequence"]["arrays"][name] = {"file": f"sequence/{name}.zlib", "dtype": "float16", "shape": [n, height, width, 3],
                                              "compression": "zlib", "bytes": len(raw)}
    edited["files"] = file_table(copy)
    (copy / "manifest.json").write_text(json.dumps(edited, indent=1))
    return edited


def test_java_core_takes_the_inputs_the_manifest_lists(java_core, tiny_bundle, manifest, tmp_path):
    """Nothing in the Java core is tied to MNSS's inputs: an extra input resource is read, checked
    and fed to the pipeline; a wrong golden array for it is refused, naming it."""
    edited = with_extra_input(tiny_bundle, manifest, tmp_path / "bundle")
    assert schema_problems(edited) == [] and check_files(tmp_path / "bundle", edited) == []
    assert java_core.tool("verify", str(tmp_path / "bundle")) == ""
    summary = json.loads(java_core.tool("read", str(tmp_path / "bundle"), str(tmp_path / "log")))
    assert summary["golden_inputs"] == [r["name"] for r in edited["resources"] if r["role"] == "input"]
    assert "hr_albedo" in summary["golden_inputs"] and summary["schedule_problems"] == []
    report = java_core.tool("selftest", str(tmp_path / "bundle"), str(tmp_path / "dump"), "0")
    assert report.splitlines()[0] == "inputs: color,depth,hr_albedo,motion"
    assert report.strip().endswith("PASSED"), report
    assert list(read_dump(tmp_path / "dump").tensors) == [*(b["tensor"] for b in manifest["boundary"]), "display"]

    edited["golden"]["frames"][1]["arrays"]["hr_albedo"]["shape"] = [edited["hr_size"][0], edited["hr_size"][1], 3]
    (tmp_path / "bundle" / "manifest.json").write_text(json.dumps(edited))
    result = java_core.java("io.mnsskit.core.ContractTool", "read", str(tmp_path / "bundle"), str(tmp_path / "log2"))
    assert result.returncode != 0
    assert "golden/frames/1/arrays/hr_albedo is float16 [64, 48, 3]; resource 'hr_albedo' needs float16 [48, 64, 3]" in result.stderr


def test_java_core_reads_the_recorded_sequence(java_core, tiny_bundle, manifest, synthetic_dataset):
    """The sequence `export --sequence` wrote, as the Java core decompresses it: every input
    resource, every frame's bytes (SHA-256) and values equal to numpy's reading of the same files."""
    import hashlib

    from recorded_sequence import SEQUENCE_FRAMES
    from mnss_kit.export.sequence import read_sequence_array

    sequence = manifest["sequence"]
    inputs = [r["name"] for r in manifest["resources"] if r["role"] == "input"]
    assert sequence["frame_count"] == SEQUENCE_FRAMES and list(sequence["arrays"]) == inputs
    java = json.loads(java_core.tool("sequence", str(tiny_bundle)))
    assert java["frames"] == [[f["reset"], -1 if f["jitter_index"] is None else f["jitter_index"]] for f in sequence["frames"]]
    assert java["frames"][0][0] is True
    for name, entry in sequence["arrays"].items():
        data = read_sequence_array(tiny_bundle, entry)
        expected = [[hashlib.sha256(frame.tobytes()).hexdigest(), float(frame.flat[0]), float(frame.flat[-1])] for frame in data]
        assert java["arrays"][name] == expected, name
    # frames 0.. of the sequence are the golden frames' inputs (both from the dataset's first sequence)
    for golden in manifest["golden"]["frames"]:
        for name in inputs:
            array = golden["arrays"][name]
            stored = np.fromfile(tiny_bundle / array["file"], array["dtype"]).reshape(array["shape"])
            np.testing.assert_array_equal(read_sequence_array(tiny_bundle, sequence["arrays"][name])[golden["index"]], stored)


def test_java_core_refuses_a_damaged_sequence(java_core, tiny_bundle, manifest, tmp_path):
    copy = Path(shutil.copytree(tiny_bundle, tmp_path / "bundle"))
    entry = manifest["sequence"]["arrays"]["motion"]
    (copy / entry["file"]).write_bytes((copy / entry["file"]).read_bytes()[:-30])
    result = java_core.java("io.mnsskit.core.ContractTool", "sequence", str(copy))
    assert result.returncode != 0 and f"{entry['file']}: does not decompress to the {entry['bytes']} bytes" in result.stderr
    edited = json.loads(json.dumps(manifest))
    edited["sequence"]["arrays"]["depth"]["shape"][1] += 1
    (copy / "manifest.json").write_text(json.dumps(edited))
    result = java_core.java("io.mnsskit.core.ContractTool", "sequence", str(copy))
    assert result.returncode != 0 and "sequence/arrays/depth" in result.stderr, result.stderr[-2000:]
