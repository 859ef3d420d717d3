"""Inputs a user can get wrong outside the pipeline's own artefacts: binary files given as YAML
configs, --a16 and --resolution beyond what exists, captures holding Git LFS pointers or corrupt
EXR files.  Each: a non-zero exit, one stderr line naming the file, key or tensor, no traceback,
nothing written (and no noise of the OpenEXR library on either descriptor: capfd)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from mnss_kit.model import checkpoint
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model, randomise_convs

from fault_helpers import assert_one_line_fault, run_cli

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dataset"))
from capture_helpers import write_nss_capture, write_packed_capture  # noqa: E402

LFS_POINTER = ("version https://git-lfs.github.com/spec/v1\n"
               "oid sha256:4d7a214614ab2935c943f9e0ff69d22eadbb8f32b1258daaa5e2ca24d17e2393\nsize 24593\n")


@pytest.fixture(scope="module")
def tiny_ckpt(tmp_path_factory) -> Path:
    torch.manual_seed(0)
    model = randomise_convs(build_model(load_model_config("mnss_x2_tiny")).eval())
    return checkpoint.save(tmp_path_factory.mktemp("input_faults") / "tiny.pt", model, {"jitter_pattern": "grid"})


def _binary(path: Path) -> Path:
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8).tobytes())
    return path


def _nul_bytes(path: Path) -> Path:
    path.write_bytes(b"name: phone\n\x00\x01\x02\x03 not text\n")
    return path


def _capture(scratch: Path, damage) -> Path:
    write_nss_capture(scratch / "cap", frames=4)
    return damage(scratch / "cap")


def _lfs_pointer(cap: Path) -> Path:
    path = cap / "x2" / "color" / "0000" / "0001.exr"
    path.write_text(LFS_POINTER)
    return path


def _truncated(cap: Path) -> Path:
    path = cap / "ground_truth" / "0000" / "0002.exr"
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    return path


def yaml_case(command: list, make: callable):
    def prepare(scratch: Path, ckpt: Path, data: Path):
        path = make(scratch / "given.yaml")
        return [a if a != "{yaml}" else path for a in command], [str(path), "not a YAML text file"]
    return prepare


def import_case(damage, words: list[str]):
    def prepare(scratch: Path, ckpt: Path, data: Path):
        path = _capture(scratch, damage)
        return ["data", "import", "nss", scratch / "cap", "--out", scratch / "out"], [str(path), *words]
    return prepare


def images_lfs_pointer(scratch: Path, ckpt: Path, data: Path):
    write_packed_capture(scratch / "cap")
    path = scratch / "cap" / "seq0" / "lr" / "depth" / "0002.png"
    path.write_text(LFS_POINTER)
    return ["data", "import", "images", scratch / "cap", "--mapping", "packed8", "--out", scratch / "out"], \
        [str(path), "Git LFS pointer"]


def a16_beyond_the_graph(scratch: Path, ckpt: Path, data: Path):
    argv = ["quantize", ckpt, "--data", data, "--out", scratch / "out", "--frames", 2, "--pipeline-frames", 0,
            "--a16", 1000, "--no-progress"]
    return argv, ["--a16 1000", "activation tensors", "at most"]


def resolution(command: str):
    def prepare(scratch: Path, ckpt: Path, data: Path):
        argv = {"split": ["split", ckpt, "--device", "snapdragon_8_gen_1", "--resolution", "100000x100000"],
                "export": ["export", ckpt, "--out", scratch / "out", "--resolution", "100000x100000", "--no-progress"]}[command]
        return argv, ["--resolution 100000x100000", "at most 8192"]
    return prepare


CASES = {
    "split-device-binary": yaml_case(["split", "mnss_x2", "--device", "{yaml}"], _binary),
    "split-device-nul-bytes": yaml_case(["split", "mnss_x2", "--device", "{yaml}"], _nul_bytes),
    "render-config-binary": yaml_case(["render", "{yaml}", "--out", "out", "--no-progress"], _binary),
    "quantize-a16-beyond-the-graph": a16_beyond_the_graph,
    "split-resolution-huge": resolution("split"),
    "export-resolution-huge": resolution("export"),
    "import-nss-lfs-pointer": import_case(_lfs_pointer, ["Git LFS pointer", "git lfs pull"]),
    "import-nss-truncated-exr": import_case(_truncated, ["not a valid OpenEXR file"]),
    "import-images-lfs-pointer": images_lfs_pointer,
}


@pytest.mark.parametrize("prepare", CASES.values(), ids=CASES.keys())
def test_bad_input_is_one_line_naming_it(prepare, tiny_ckpt, synthetic_dataset, tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)  # "out" of render-config-binary lands in the scratch directory
    argv, words = prepare(tmp_path, tiny_ckpt, synthetic_dataset)
    line = assert_one_line_fault(argv, words, 2, tmp_path, capfd)
    assert "Warning:" not in line  # OpenEXR's own messages stay out


def test_arm_sample_layout_imports_and_passes_data_check(tmp_path, capfd):
    """Arm's sample captures list every frame in NNNN.json but ship files for the first ones."""
    write_nss_capture(tmp_path / "cap", frames=5)
    for folder in [p for p in (tmp_path / "cap").rglob("0000") if p.is_dir()]:
        for path in sorted(folder.glob("*.exr"))[1:]:
            path.unlink()
    code, lines, out = run_cli(["data", "import", "nss", tmp_path / "cap", "--out", tmp_path / "out"], capfd)
    assert code == 0, lines
    assert any("frame files for 1 of the 5 frames 0000.json lists (4 missing)" in line for line in lines)  # on stderr
    code, lines, _ = run_cli(["data", "check", tmp_path / "out" / "x2"], capfd)
    assert code == 0, lines
