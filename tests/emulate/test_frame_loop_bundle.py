"""The emulator on a real bundle written by `mnss-kit export`: golden frames, runtime equality, bad bundles.

The bundle holds the default MNSS x2 config (the model that ships) with perturbed untrained
weights, exported at 64x48 from a 12-frame synthetic sequence.  Over all 12 recurrent frames the
numpy NPU stage must give the same int8 values as LiteRT under each kernel set, and a numpy
profile other than the runtime's must not.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mnss_kit.dataset.format import read_meta
from mnss_kit.emulate.frame_loop import Emulator
from mnss_kit.emulate.run import run_dataset, sequence_frames
from mnss_kit.errors import UserError
from mnss_kit.export.manifest import file_table
from mnss_kit.ops.runtimes import runtime_names

FRAMES = 12
LITERT_PROFILES = runtime_names("litert")
_BUNDLES: dict[str, Path] = {}


def shared_bundle(tmp_path_factory) -> Path:
    """The test bundle and its data (``<root>/bundle``, ``<root>/data/pan``), exported once per session."""
    if "root" not in _BUNDLES:
        import torch

        from mnss_kit.cli import main
        from mnss_kit.dataset.synthetic import write_synthetic_sequence
        from mnss_kit.model import checkpoint
        from mnss_kit.model.config import load_model_config
        from mnss_kit.model.families import build_model, randomise_convs

        root = tmp_path_factory.mktemp("emulate_bundle")
        write_synthetic_sequence(root / "data" / "pan", name="pan", lr_size=(32, 24), scale=2, frames=FRAMES)
        torch.manual_seed(0)
        model = build_model(load_model_config("mnss_x2")).eval()
        randomise_convs(model)  # the last convs start at zero: random weights so every tensor carries signal
        ckpt = checkpoint.save(root / "mnss_x2.pt", model, {"jitter_pattern": "grid"})
        code = main(["export", str(ckpt), "--out", str(root / "bundle"), "--resolution", "64x48",
                     "--data", str(root / "data"), "--no-progress"])
        assert code == 0
        _BUNDLES["root"] = root
    return _BUNDLES["root"]


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    return shared_bundle(tmp_path_factory)


@pytest.fixture(scope="module")
def frames(root) -> list[dict]:
    seq = root / "data" / "pan"
    return [f for _, f, _ in sequence_frames(seq, read_meta(seq), None, ["color", "depth", "motion"])]


@pytest.fixture
def bundle_copy(root, tmp_path) -> Path:
    return Path(shutil.copytree(root / "bundle", tmp_path / "bundle"))


def golden_inputs(bundle: Path):
    manifest = json.loads((bundle / "manifest.json").read_text())

    def read(entry):
        return np.fromfile(bundle / entry["file"], dtype=np.dtype(entry["dtype"]).newbyteorder("<")).reshape(entry["shape"])

    for frame in manifest["golden"]["frames"]:
        arrays = {k: read(v) for k, v in frame["arrays"].items()}
        inputs = {"color": arrays["color"].astype(np.float32), "depth": arrays["depth"], "motion": arrays["motion"],
                  "jitter": frame["jitter"], "reset": frame["reset"]}
        yield inputs, arrays


@pytest.mark.parametrize("npu_backend", ["numpy", "litert"])
def test_golden_frames_reproduced_bit_exactly(root, npu_backend):
    bundle = root / "bundle"
    profile = json.loads((bundle / "manifest.json").read_text())["golden"]["profile"]  # the runtime's name
    emulator = Emulator(bundle, profile, npu_backend)
    for t, (inputs, expected) in enumerate(golden_inputs(bundle)):
        result = emulator.run_frame(inputs, keep_all=True)
        assert np.array_equal(result.tensors[emulator.spec.boundary("gpu->npu")["tensor"]], expected["npu_input"]), f"frame {t} npu_input"
        assert np.array_equal(result.npu_output, expected["npu_output"]), f"frame {t} npu_output"
        assert np.array_equal(result.display, expected["display"]), f"frame {t} display"


@pytest.mark.slow
@pytest.mark.parametrize("profile", LITERT_PROFILES)
def test_numpy_equals_runtime_over_recurrent_frames(root, frames, profile):
    """Two independent recurrent runs, numpy and LiteRT kernels: every int8 tensor identical, every frame."""
    emulated = Emulator(root / "bundle", profile, "numpy")
    runtime = Emulator(root / "bundle", profile, "litert")
    compared = 0
    for t, frame in enumerate(frames):
        a, b = emulated.run_frame(frame, keep_all=True), runtime.run_frame(frame, keep_all=True)
        for name, value in b.tensors.items():
            if value.dtype == np.int8:
                bad = int(np.count_nonzero(a.tensors[name] != value))
                assert bad == 0, f"{profile}: frame {t} tensor '{name}': {bad} of {value.size} int8 values differ"
                compared += value.size
        assert np.array_equal(a.display, b.display), f"frame {t} display"
    assert len(frames) >= 10 and compared > 0


@pytest.mark.slow
def test_wrong_profile_is_detected(root, frames):
    """Given the runtime's own NPU inputs, every other numpy profile disagrees somewhere in the NPU graph."""
    for runtime in LITERT_PROFILES:
        lit = Emulator(root / "bundle", runtime, "litert")
        runs = [lit.run_frame(f, keep_all=True) for f in frames]
        for other in LITERT_PROFILES:
            npu = Emulator(root / "bundle", other, "numpy")
            name_in = npu.spec.boundary("gpu->npu")["tensor"]
            bad = 0
            for r in runs:
                out = npu.npu.run({name_in: r.tensors[name_in]}, keep_all=True)
                bad += sum(int(np.count_nonzero(v != r.tensors[n])) for n, v in out.items() if n in r.tensors)
            assert (bad == 0) == (other == runtime), f"runtime {runtime}, numpy {other}: {bad} mismatches"


def test_onnxruntime_backend_runs_the_bundle(root, frames):
    """On the first (reset) frame both NPU stages see the same input.  Their roundings differ near
    ties by at most 1 LSB per op (tests/quantize); through the whole graph such a difference can
    grow downstream, so: at most 2 LSB anywhere, and 99% of values within 1."""
    emulator = Emulator(root / "bundle", "ort-cpu", "onnxruntime")
    reference = Emulator(root / "bundle", "tflite-ref", "numpy")
    first = [(emulator.run_frame(f), reference.run_frame(f)) for f in frames[:3]][0]
    a, b = first
    assert a.npu_output.shape == b.npu_output.shape and a.npu_output.dtype == np.int8
    diff = np.abs(a.npu_output.astype(np.int16) - b.npu_output)
    assert int(diff.max()) <= 2 and np.count_nonzero(diff > 1) < 0.01 * diff.size


def test_numpy_equals_onnxruntime_over_recurrent_frames(root, frames):
    emulated = Emulator(root / "bundle", "ort-cpu", "numpy")
    runtime = Emulator(root / "bundle", "ort-cpu", "onnxruntime")
    for t, frame in enumerate(frames):
        a, b = emulated.run_frame(frame), runtime.run_frame(frame)
        assert np.array_equal(a.npu_output, b.npu_output), f"frame {t}"
        assert np.array_equal(a.display, b.display), f"frame {t} display"
    assert len(frames) >= 10


def need_egl():
    from mnss_kit.gpu import mesa

    try:
        mesa.create_context()
    except UserError as e:
        pytest.skip(str(e))


def test_mesa_backend_runs_the_bundle_shaders(root, frames):
    need_egl()
    emulator = Emulator(root / "bundle", gpu_backend="mesa")
    reference = Emulator(root / "bundle")
    for frame in frames[:2]:
        a, b = emulator.run_frame(frame), reference.run_frame(frame)
        assert int(np.max(np.abs(a.display.astype(np.int16) - b.display))) <= 1


def test_mesa_backend_compiles_the_files_in_the_bundle(bundle_copy, frames):
    """A shader file changed in the bundle is what the Mesa backend compiles (here: a broken one)."""
    need_egl()
    path = bundle_copy / "shaders" / "warp_pass.comp"
    path.write_text(path.read_text().replace("void main()", "void main() { this does not compile; }\nvoid unused()", 1))
    with pytest.raises(UserError, match=r"warp_pass\.comp: \d+ bytes, manifest\.json says"):
        Emulator(bundle_copy, gpu_backend="mesa")
    rehash(bundle_copy)
    emulator = Emulator(bundle_copy, gpu_backend="mesa")
    emulator.run_frame(frames[0])  # a reset frame does not warp
    with pytest.raises(UserError, match=r"warp_pass\.comp: does not compile"):
        emulator.run_frame(frames[1])


# -- bad bundles -----------------------------------------------------------------------------------

def rehash(bundle: Path) -> None:
    """Rewrite the manifest's file table, as a tool that rewrote a file correctly would."""
    manifest = json.loads((bundle / "manifest.json").read_text())
    manifest["files"] = file_table(bundle)
    (bundle / "manifest.json").write_text(json.dumps(manifest))


def edit_manifest(bundle: Path, change) -> None:
    manifest = json.loads((bundle / "manifest.json").read_text())
    change(manifest)
    (bundle / "manifest.json").write_text(json.dumps(manifest))


def test_missing_file(bundle_copy):
    (bundle_copy / "npu.tflite").unlink()
    with pytest.raises(UserError, match=r"npu\.tflite: missing"):
        Emulator(bundle_copy)


def test_changed_file_fails_its_hash(bundle_copy):
    data = bytearray((bundle_copy / "gpu_weights.bin").read_bytes())
    data[100] ^= 0xFF
    (bundle_copy / "gpu_weights.bin").write_bytes(bytes(data))
    with pytest.raises(UserError, match=r"gpu_weights\.bin: SHA-256"):
        Emulator(bundle_copy)


def test_truncated_model(bundle_copy):
    path = bundle_copy / "npu.tflite"
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 3])
    rehash(bundle_copy)
    with pytest.raises(UserError, match=r"npu\.tflite is corrupt"):
        Emulator(bundle_copy)


def test_unknown_operator(bundle_copy):
    import flatbuffers
    from ai_edge_litert import schema_py_generated as schema

    path = bundle_copy / "npu.tflite"
    model = schema.ModelT.InitFromPackedBuf(bytearray(path.read_bytes()), 0)
    code = next(c for c in model.operatorCodes if c.builtinCode == schema.BuiltinOperator.ADD)
    code.builtinCode = code.deprecatedBuiltinCode = schema.BuiltinOperator.SQUARED_DIFFERENCE
    builder = flatbuffers.Builder(1024)
    builder.Finish(model.Pack(builder), file_identifier=b"TFL3")
    path.write_bytes(bytes(builder.Output()))
    rehash(bundle_copy)
    with pytest.raises(UserError, match=r"operator \d+ \(SQUARED_DIFFERENCE -> '.+'\): the emulator does not implement"):
        Emulator(bundle_copy)


def test_manifest_shape_differs_from_model(bundle_copy):
    name = {}

    def change(m):
        entry = m["npu"]["tensors"][2]
        name["tensor"] = entry["name"]
        entry["shape"] = [1, 7, 7, 7]

    edit_manifest(bundle_copy, change)
    with pytest.raises(UserError, match=rf"tensor '{name['tensor']}': shape .*manifest\.json says \[1, 7, 7, 7\]"):
        Emulator(bundle_copy)


def test_manifest_quantization_differs_from_model(bundle_copy):
    edit_manifest(bundle_copy, lambda m: m["boundary"][0].update(scale=0.5))
    with pytest.raises(UserError, match=r"boundary tensor '.+': scale 0\.5 differs"):
        Emulator(bundle_copy)


def test_not_a_bundle(tmp_path):
    with pytest.raises(UserError, match="bundle directory not found"):
        Emulator(tmp_path / "nothing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(UserError, match="manifest.json: missing"):
        Emulator(tmp_path / "empty")


def test_data_of_another_scale_is_a_user_error(root, tmp_path):
    from mnss_kit.dataset.synthetic import write_synthetic_sequence

    write_synthetic_sequence(tmp_path / "x3", name="x3", lr_size=(32, 24), scale=3, frames=2)
    with pytest.raises(UserError, match="scale 3, the bundle is x2"):
        run_dataset(Emulator(root / "bundle"), tmp_path / "x3")


def test_emulator_exactness_script_counts_no_difference_on_the_bundle(root):
    """scripts/emulator_exactness.py, as the docs run it, on this bundle: every profile exact."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
    from emulator_exactness import bundle_frames, compare

    frames = bundle_frames(root / "bundle", root / "data" / "pan", 3)
    for profile in ("tflite-ref", "ort-cpu"):
        result = compare(root / "bundle", frames, profile)
        assert result["int8_values_compared"] > 0 and result["int8_values_differing"] == 0, (profile, result)
