"""A bundle edited and re-hashed, so that every file still matches the manifest's SHA-256: ``bundle
check`` holds the manifest to itself, ``bundle check --run`` replays the golden frames and compiles
the shaders, and ``emulate`` on the bundle's own golden sequence compares its first frames.  Each
case: a non-zero exit, one stderr line naming the file or key, no traceback, nothing written."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
import torch

from mnss_kit.export.manifest import sha256_bytes
from mnss_kit.fileio import sha256_file
from mnss_kit.model import checkpoint
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model, randomise_convs

from fault_helpers import assert_one_line_fault, run_cli


@pytest.fixture(scope="module")
def bundle(tmp_path_factory, synthetic_dataset) -> Path:
    """The tiny x2 model exported at 64x48 with two golden frames from the synthetic 'pan' sequence."""
    root = tmp_path_factory.mktemp("bundle_faults")
    torch.manual_seed(0)
    model = randomise_convs(build_model(load_model_config("mnss_x2_tiny")).eval())
    ckpt = checkpoint.save(root / "tiny.pt", model, {"jitter_pattern": "grid"})
    out = root / "bundle"
    from mnss_kit.cli import main

    assert main(["export", str(ckpt), "--out", str(out), "--resolution", "64x48", "--data", str(synthetic_dataset),
                 "--golden-frames", "2", "--no-progress"]) == 0
    return out


# --- edits, each followed by the re-hash an exporter that wrote the file so would do ----------------

def _manifest(bundle: Path) -> dict:
    return json.loads((bundle / "manifest.json").read_text())


def _save(bundle: Path, manifest: dict, *changed: str) -> None:
    for name in changed:
        manifest["files"][name] = {"bytes": (bundle / name).stat().st_size, "sha256": sha256_file(bundle / name)}
    (bundle / "manifest.json").write_text(json.dumps(manifest))


def scale_4_with_x2_sizes(bundle: Path) -> list[str]:
    m = _manifest(bundle)
    m["scale"] = 4
    _save(bundle, m)
    return ["manifest.json", "scale 4", "hr_size [64, 48]"]


def hr_size_off(bundle: Path) -> list[str]:
    m = _manifest(bundle)
    m["hr_size"] = [66, 48]
    _save(bundle, m)
    return ["manifest.json", "hr_size [66, 48] is not scale 2 x lr_size [32, 24]"]


def jitter_table_of_another_scale(bundle: Path) -> list[str]:
    m = _manifest(bundle)
    m["jitter"]["sequence"][1]["subpixel"] = [2, 2]
    _save(bundle, m)
    return ["manifest.json", "jitter.sequence[1]", "subpixel [2, 2]"]


def gpu_weights_times_3(bundle: Path) -> list[str]:
    m = _manifest(bundle)
    weights = m["gpu"]["weights"]
    path = bundle / weights["file"]
    raw = (np.frombuffer(path.read_bytes(), "<f4") * np.float32(3)).astype("<f4").tobytes()
    path.write_bytes(raw)
    for block in weights["blocks"]:
        block["sha256"] = sha256_bytes(raw[block["offset"]:block["offset"] + block["bytes"]])
    _save(bundle, m, weights["file"])
    return ["golden/frame_000", "do not reproduce golden frame 0"]


def golden_npu_output_flipped(bundle: Path) -> list[str]:
    m = _manifest(bundle)
    name = m["golden"]["frames"][1]["arrays"]["npu_output"]["file"]
    data = bytearray((bundle / name).read_bytes())
    for i in np.random.default_rng(0).choice(len(data), min(2000, len(data)), replace=False):
        data[i] ^= 0xFF
    (bundle / name).write_bytes(bytes(data))
    _save(bundle, m, name)
    return ["golden/frame_001", "npu_output"]


def shader_does_not_compile(bundle: Path) -> list[str]:
    from mnss_kit.errors import UserError
    from mnss_kit.gpu.mesa import create_context

    try:
        create_context()
    except UserError:
        pytest.skip("no EGL: bundle check --run compiles no shader here")
    m = _manifest(bundle)
    name = m["gpu"]["passes"][0]["file"]
    text = (bundle / name).read_text()
    (bundle / name).write_text(text.replace("void main()", "void main() { no_such_function(); }\nvoid unused()", 1))
    _save(bundle, m, name)
    return [name, "does not compile", "no_such_function"]


def bundle_check(edit: Callable[[Path], list[str]], *flags: str):
    def prepare(bundle: Path, data: Path, scratch: Path):
        words = edit(bundle)
        return ["bundle", "check", *flags, bundle], words, 1
    return prepare


def emulate_golden_sequence(edit: Callable[[Path], list[str]]):
    def prepare(bundle: Path, data: Path, scratch: Path):
        edit(bundle)
        argv = ["emulate", bundle, "--data", data / "pan", "--out", scratch / "out", "--frames", 3, "--no-progress"]
        return argv, [str(bundle), "'pan' is the bundle's golden sequence", "frame 0", "golden/frame_000"], 2
    return prepare


CASES = {
    "check-scale-4-with-x2-sizes": bundle_check(scale_4_with_x2_sizes),
    "check-hr-size-not-scale-x-lr": bundle_check(hr_size_off),
    "check-jitter-subpixel-of-another-scale": bundle_check(jitter_table_of_another_scale),
    "check-run-gpu-weights-x3": bundle_check(gpu_weights_times_3, "--run"),
    "check-run-golden-npu-output-flipped": bundle_check(golden_npu_output_flipped, "--run"),
    "check-run-shader-does-not-compile": bundle_check(shader_does_not_compile, "--run"),
    "emulate-golden-sequence-gpu-weights-x3": emulate_golden_sequence(gpu_weights_times_3),
}


@pytest.mark.parametrize("prepare", CASES.values(), ids=CASES.keys())
def test_rehashed_edit_is_refused_in_one_line(prepare, bundle, synthetic_dataset, tmp_path, capsys):
    copy = Path(shutil.copytree(bundle, tmp_path / "bundle"))
    argv, words, status = prepare(copy, synthetic_dataset, tmp_path)
    assert_one_line_fault(argv, words, status, tmp_path, capsys)


def test_the_same_edits_pass_the_hash_checks(bundle, tmp_path, capsys):
    """What --run adds: the replay-only edits keep every hash, so the plain check passes them."""
    for edit in (gpu_weights_times_3, golden_npu_output_flipped):
        copy = Path(shutil.copytree(bundle, tmp_path / edit.__name__))
        edit(copy)
        code, lines, _ = run_cli(["bundle", "check", copy], capsys)
        assert code == 0 and not lines, lines


def test_the_good_bundle_passes_check_run_and_emulate(bundle, synthetic_dataset, tmp_path, capsys, caplog):
    caplog.set_level(logging.INFO)
    code, lines, out = run_cli(["bundle", "check", "--run", bundle], capsys)
    assert code == 0 and not [line for line in lines if not line.startswith("INFO ")], lines
    assert "2 golden frames replayed" in out
    argv = ["emulate", bundle, "--data", synthetic_dataset / "pan", "--out", tmp_path / "out", "--frames", 3, "--no-progress"]
    code, lines, _ = run_cli(argv, capsys)
    assert code == 0, lines
    assert any("pan: frames 0..1 reproduce the bundle's golden frames" in line for line in lines), lines
