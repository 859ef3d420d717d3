"""Damaged and mismatched artefacts through the CLI: each is refused with one line naming the culprit.

Every case starts from good artefacts made once per module (a tiny checkpoint and a narrower
one, their quantize directories, a bundle, an emulator dump), damages a private copy, runs one
command in-process and asserts: a non-zero exit, exactly one line on stderr (log records
included) that names the file, key or tensor, no traceback, and nothing written where a later
command would read it (no ``--out`` directory, no ``.staging.`` leftovers).
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
import torch

from mnss_kit.cli import main
from mnss_kit.export.manifest import sha256_bytes
from mnss_kit.fileio import sha256_file
from mnss_kit.model import checkpoint
from mnss_kit.model.config import load_model_config
from mnss_kit.model.families import build_model, randomise_convs

from fault_helpers import run_cli, snapshot


@dataclasses.dataclass
class Artefacts:
    root: Path
    data: Path
    ckpt: Path  # mnss_x2_tiny, random weights
    narrow: Path  # the same family and scale, narrower reconstruction net
    qdir: Path  # mnss-kit quantize of ckpt
    narrow_qdir: Path  # mnss-kit quantize of narrow
    bundle: Path  # mnss-kit export of qdir
    dump: Path  # mnss-kit emulate --dump of bundle, 2 frames of 'pan'


def _save_model(path: Path, seed: int, **overrides) -> Path:
    torch.manual_seed(seed)
    config = dataclasses.replace(load_model_config("mnss_x2_tiny"), **overrides)
    return checkpoint.save(path, randomise_convs(build_model(config).eval()), {"jitter_pattern": "grid"})


def _cli(*argv) -> None:
    assert main([str(a) for a in argv]) == 0, argv


@pytest.fixture(scope="module")
def made(tmp_path_factory, synthetic_dataset) -> Artefacts:
    root = tmp_path_factory.mktemp("artefacts")
    ckpt, narrow = _save_model(root / "tiny.pt", 0), _save_model(root / "narrow.pt", 1, recon_width=8)
    qdir, narrow_qdir, bundle, emulated = root / "int8", root / "narrow-int8", root / "bundle", root / "emulated"
    for model, out in ((ckpt, qdir), (narrow, narrow_qdir)):
        _cli("quantize", model, "--data", synthetic_dataset, "--out", out, "--frames", 2, "--pipeline-frames", 0, "--no-progress")
    _cli("export", qdir, "--checkpoint", ckpt, "--out", bundle, "--data", synthetic_dataset, "--golden-frames", 2, "--no-progress")
    _cli("emulate", bundle, "--data", synthetic_dataset / "pan", "--out", emulated, "--dump", "--frames", 2, "--no-progress")
    return Artefacts(root, synthetic_dataset, ckpt, narrow, qdir, narrow_qdir, bundle, emulated / "pan" / "dump")


# --- damage helpers: each takes a private copy's path ---------------------------------------------

def _edit_json(path: Path, edit: Callable[[dict], None]) -> None:
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))


def _truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 3])


def _garble(path: Path) -> None:
    """Same size and header (the .tflite identifier survives), random bytes after it."""
    data = path.read_bytes()
    path.write_bytes(data[:8] + np.random.default_rng(0).integers(0, 256, len(data) - 8, dtype=np.uint8).tobytes())


def _poison_checkpoint(src: Path, dst: Path, tensor: str, value: float) -> Path:
    payload = torch.load(src, weights_only=True)
    payload["state_dict"][tensor].view(-1)[0] = value
    torch.save(payload, dst)
    return dst


def _rehash(bundle: Path, name: str, edit: Callable[[dict], None] = lambda m: None) -> None:
    """Record ``name``'s new size and hash in the manifest, as an exporter that wrote it so would."""
    path = bundle / name

    def update(manifest: dict) -> None:
        edit(manifest)
        manifest["files"][name] = {"bytes": path.stat().st_size, "sha256": sha256_file(path)}

    _edit_json(bundle / "manifest.json", update)


def _nan_in_gpu_weights(bundle: Path) -> str:
    """A NaN in the first weight block, with the block's and the file's hashes updated to match."""
    manifest = json.loads((bundle / "manifest.json").read_text())
    block = manifest["gpu"]["weights"]["blocks"][0]
    path = bundle / manifest["gpu"]["weights"]["file"]
    data = bytearray(path.read_bytes())
    data[block["offset"]:block["offset"] + 4] = np.float32(np.nan).tobytes()
    path.write_bytes(bytes(data))
    digest = sha256_bytes(bytes(data[block["offset"]:block["offset"] + block["bytes"]]))
    _rehash(bundle, path.name, lambda m: m["gpu"]["weights"]["blocks"][0].update(sha256=digest))
    return block["name"]


def _inf_in_golden(bundle: Path, key: str) -> str:
    manifest = json.loads((bundle / "manifest.json").read_text())
    array = manifest["golden"]["frames"][1]["arrays"][key]
    path = bundle / array["file"]
    values = np.frombuffer(path.read_bytes(), dtype=np.dtype(array["dtype"]).newbyteorder("<")).copy()
    values[7] = np.inf
    path.write_bytes(values.tobytes())
    _rehash(bundle, array["file"])
    return array["file"]


def _drop_tensor(dump: Path, frame: int, tensor: str) -> None:
    path = dump / f"frame_{frame:05d}.npz"
    with np.load(path) as npz:
        arrays = {k: npz[k] for k in npz.files if k != tensor}
    with open(path, "wb") as f:
        np.savez(f, **arrays)


# --- cases: prepare(artefacts, scratch) -> (argv, words the error line must hold) -----------------

def _copy(src: Path, scratch: Path) -> Path:
    return Path(shutil.copytree(src, scratch / src.name))


def _export_qdir(qdir: Path, ckpt: Path | None, scratch: Path) -> list:
    argv = ["export", qdir, "--out", scratch / "out", "--no-progress"]
    return argv + (["--checkpoint", ckpt] if ckpt else [])


def other_checkpoint(a: Artefacts, scratch: Path):
    return _export_qdir(a.qdir, a.narrow, scratch), ["narrow.pt", str(a.qdir), "tiny.pt", "SHA-256"]


def checkpoint_replaced_since_quantize(a: Artefacts, scratch: Path):
    qdir, moved = _copy(a.qdir, scratch), Path(shutil.copy(a.narrow, scratch / "model.pt"))
    _edit_json(qdir / "report.json", lambda r: r["checkpoint"].update(path=str(moved)))
    return _export_qdir(qdir, None, scratch), [str(moved), "changed since", str(qdir)]


def missing_file(name: str):
    def prepare(a: Artefacts, scratch: Path):
        qdir = _copy(a.qdir, scratch)
        (qdir / name).unlink()
        return _export_qdir(qdir, a.ckpt, scratch), [str(qdir), f"missing {name}"]
    return prepare


def report_without_checkpoint_hash(a: Artefacts, scratch: Path):
    qdir = _copy(a.qdir, scratch)
    _edit_json(qdir / "report.json", lambda r: r["checkpoint"].pop("sha256"))
    return _export_qdir(qdir, a.ckpt, scratch), [str(qdir / "report.json"), "checkpoint.sha256"]


def not_json(name: str):
    def prepare(a: Artefacts, scratch: Path):
        qdir = _copy(a.qdir, scratch)
        _truncate(qdir / name)
        return _export_qdir(qdir, a.ckpt, scratch), [str(qdir / name), "JSON"]
    return prepare


def damaged_npu_file(name: str, damage: Callable[[Path], None]):
    def prepare(a: Artefacts, scratch: Path):
        qdir = _copy(a.qdir, scratch)
        damage(qdir / name)
        return _export_qdir(qdir, a.ckpt, scratch), [str(qdir / name)]
    return prepare


def onnx_of_another_model(a: Artefacts, scratch: Path):
    qdir = _copy(a.qdir, scratch)
    shutil.copy(a.narrow_qdir / "npu_qdq.onnx", qdir / "npu_qdq.onnx")
    return _export_qdir(qdir, a.ckpt, scratch), [str(qdir / "npu_qdq.onnx"), "tensor"]


def non_finite_weight(command: str, tensor: str, value: float):
    def prepare(a: Artefacts, scratch: Path):
        bad = _poison_checkpoint(a.ckpt, scratch / "bad.pt", tensor, value)
        argv = [command, bad, "--data", a.data, "--out", scratch / "out", "--no-progress"]
        return argv + (["--frames", 2, "--pipeline-frames", 0] if command == "quantize" else []), [str(bad), f"'{tensor}'", "NaN or Inf"]
    return prepare


def nan_gpu_weights(a: Artefacts, scratch: Path):
    bundle = _copy(a.bundle, scratch)
    block = _nan_in_gpu_weights(bundle)
    return ["bundle", "check", bundle], ["gpu_weights.bin", f"'{block}'", "NaN or Inf"]


def emulate_nan_gpu_weights(a: Artefacts, scratch: Path):
    bundle = _copy(a.bundle, scratch)
    block = _nan_in_gpu_weights(bundle)
    argv = ["emulate", bundle, "--data", a.data / "pan", "--out", scratch / "out", "--frames", 1, "--no-progress"]
    return argv, [str(bundle), "gpu_weights.bin", f"'{block}'", "NaN or Inf"]


def inf_golden(key: str):
    def prepare(a: Artefacts, scratch: Path):
        bundle = _copy(a.bundle, scratch)
        name = _inf_in_golden(bundle, key)
        return ["bundle", "check", bundle], [name, f"golden '{key}' of frame 1", "NaN or Inf"]
    return prepare


def dump_lacks_tensor(side: str, tensor: str):
    def prepare(a: Artefacts, scratch: Path):
        first, second = _copy(a.dump, scratch / "a"), _copy(a.dump, scratch / "b")
        damaged = first if side == "a" else second
        _drop_tensor(damaged, 1, tensor)
        return ["emulate", "--compare", first, second], [f"'{tensor}'", "frame 1", str(damaged)]
    return prepare


def dump_lacks_frame_file(a: Artefacts, scratch: Path):
    first, second = _copy(a.dump, scratch / "a"), _copy(a.dump, scratch / "b")
    (second / "frame_00001.npz").unlink()
    return ["emulate", "--compare", first, second], [str(second / "frame_00001.npz"), "missing"]


CASES = {
    # (2) a quantize directory with the wrong checkpoint, or incomplete
    "export-other-checkpoint": (other_checkpoint, 2),
    "export-checkpoint-replaced-since-quantize": (checkpoint_replaced_since_quantize, 2),
    **{f"export-qdir-without-{n}": (missing_file(n), 2) for n in ("report.json", "encodings.json", "npu.tflite", "npu_qdq.onnx")},
    "export-report-without-checkpoint-hash": (report_without_checkpoint_hash, 2),
    **{f"export-qdir-truncated-{n}": (not_json(n), 2) for n in ("report.json", "encodings.json")},
    # (3) non-finite weights
    "quantize-nan-aa-weight": (non_finite_weight("quantize", "aa.net.2.weight", float("nan")), 2),
    "export-inf-recon-bias": (non_finite_weight("export", "recon.body.0.bias", float("inf")), 2),
    "bundle-check-nan-gpu-weights": (nan_gpu_weights, 1),
    "emulate-nan-gpu-weights": (emulate_nan_gpu_weights, 2),
    "bundle-check-inf-golden-color": (inf_golden("color"), 1),
    "bundle-check-inf-golden-depth": (inf_golden("depth"), 1),
    # (4) corrupt NPU files in a quantize directory
    "export-truncated-npu_qdq.onnx": (damaged_npu_file("npu_qdq.onnx", _truncate), 2),
    "export-garbled-npu_qdq.onnx": (damaged_npu_file("npu_qdq.onnx", _garble), 2),
    "export-truncated-npu.tflite": (damaged_npu_file("npu.tflite", _truncate), 2),
    "export-garbled-npu.tflite": (damaged_npu_file("npu.tflite", _garble), 2),
    "export-npu_qdq.onnx-of-another-model": (onnx_of_another_model, 2),
    # (6) dumps that lack a tensor or a frame file
    "compare-second-lacks-tensor": (dump_lacks_tensor("b", "body_2"), 1),
    "compare-first-lacks-tensor": (dump_lacks_tensor("a", "display"), 1),
    "compare-lacks-frame-file": (dump_lacks_frame_file, 2),
}

@pytest.mark.parametrize("prepare, status", CASES.values(), ids=CASES.keys())
def test_fault_is_one_line_naming_the_culprit(prepare, status, made, tmp_path, capsys):
    argv, words = prepare(made, tmp_path)
    before = snapshot(tmp_path)
    code, lines, _ = run_cli(argv, capsys)
    assert code == status
    assert len(lines) == 1, lines
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert not (tmp_path / "out").exists()
    assert snapshot(tmp_path) == before  # inputs unchanged, nothing new beside them
    assert not list(made.root.rglob("*.staging.*"))


def test_the_good_artefacts_pass_the_same_commands(made, tmp_path, capsys):
    """The cases fail because of their damage: the undamaged artefacts go through."""
    export = ["export", made.qdir, "--checkpoint", made.ckpt, "--out", tmp_path / "out", "--data", made.data, "--golden-frames", 2,
              "--no-progress"]
    for argv in (export, ["bundle", "check", made.bundle], ["emulate", "--compare", made.dump, made.dump]):
        code, lines, _ = run_cli(argv, capsys)
        assert code == 0 and not [line for line in lines if not line.startswith("INFO ")], (argv, lines)
