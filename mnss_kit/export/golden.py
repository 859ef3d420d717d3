"""Golden frames: a few consecutive frames through the desktop reference, for an on-device self-test.

The bundle's schedule runs through :class:`mnss_kit.gpu.interpret.ScheduleRunner` on the numpy
reference passes (:class:`mnss_kit.gpu.reference.ReferencePasses`, the emulator's GPU stage, fp16
storage rounding included) and the NPU graph in LiteRT with the kernel set of a named numerics
profile, so every stored value is reproducible on a desk.  Per frame the bundle keeps every
``input`` resource exactly as its texture holds it, and the tensors a phone can read back: every
``boundary`` buffer (what crosses to and from the NPU) and the ``output`` resource.

Arrays are raw little-endian files, C order, shape and dtype in the manifest; the dtype follows
the resource's format (:data:`FORMAT_DTYPES`).  For the MNSS family::

    color       (h, w, 3) float16   the rgba16f colour texture's rgb
    depth       (h, w, 1) float32   r32f
    motion      (h, w, 2) float32   rg32f, LR pixels
    npu_input   (1, H, W, 3) int8   what insert_pack_pass writes (NHWC)
    npu_output  (1, H, W, 3) int8   what the NPU returns for that input
    display     (H, W, 3) uint8     the rgba8 display texture's rgb codes
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..gpu.interpret import ScheduleRunner
from ..gpu.reference import ReferencePasses
from ..ops.jitter import subpixel_index
from ..ops.runtimes import get_runtime, runtime_names

# texture format (or boundary buffer) -> dtype of the golden array
FORMAT_DTYPES = {"rgba16f": "float16", "rg16f": "float16", "r16f": "float16", "rgba32f": "float32", "rg32f": "float32",
                 "r32f": "float32", "rgba8": "uint8", "boundary": "int8"}
TOLERANCES = {
    "npu_input_lsb": 1,
    "npu_output_lsb": 1,
    "display_codes": 1,
    "note": "the bundled shaders reproduce the reference bit for bit on an IEEE float32 GPU; a phone GPU that "
            "contracts products into FMAs or rounds exp() differently may move a value across a rounding boundary "
            "(1 LSB), and NPU drivers may differ by 1 LSB from the profile's CPU kernels",
}


@dataclass
class GoldenFrame:
    """One frame's inputs and expected results (see the module docstring for shapes)."""

    jitter: np.ndarray  # (2,) float32, LR pixels
    reset: bool
    arrays: dict[str, np.ndarray]


def frame_from_torch(frame: dict, inputs: list[str]) -> dict:
    """A loader frame (batched NCHW torch tensors) -> the numpy frame the schedule takes (``inputs``)."""

    def hwc(key):
        return np.ascontiguousarray(frame[key][0].permute(1, 2, 0).numpy(), dtype=np.float32)

    reset = frame.get("reset")
    out = {key: hwc(key) for key in inputs}
    out["jitter"] = np.asarray(frame["jitter"][0].numpy(), np.float32)
    out["reset"] = bool(reset is not None and float(reset[0]) > 0.5)
    return out


def dataset_frames(data: Path, lr_size, scale: int, inputs: list[str], n: int) -> tuple[list[dict], str] | None:
    """The first ``n`` numpy frames (``inputs``) of the first sequence in dataset ``data`` at
    ``lr_size`` and ``scale`` with that many frames, and where they came from; None if none fits."""
    from ..dataset.format import extra_buffers_of
    from ..dataset.loader import eval_sequences

    for seq in eval_sequences(data, **extra_buffers_of(inputs), progress=False):
        if tuple(seq.meta.lr_size) == tuple(lr_size) and seq.meta.scale == scale and len(seq) >= n:
            return first_frames(seq, n, inputs), f"dataset {data}, sequence {seq.name}, frames 0..{n - 1}"
    return None


def first_frames(seq, n: int, inputs: list[str]) -> list[dict]:
    """The first ``n`` frames of dataset sequence ``seq`` as numpy frames; ``UserError`` on NaN or Inf."""
    frames = []
    for t, frame in enumerate(seq):
        if t >= n:
            break
        frames.append(frame_from_torch(frame, inputs))
    if not all(np.isfinite(f[k]).all() for f in frames for k in inputs):
        raise UserError(f"frames 0..{n - 1} of sequence '{seq.name}' contain NaN or Inf")
    return frames


def input_dtypes(resources: list[dict]) -> dict[str, str]:
    """``{input resource: dtype}`` in manifest order: the inputs as their textures hold them."""
    return {r["name"]: FORMAT_DTYPES[r["format"]] for r in resources if r["role"] == "input"}


def golden_arrays(resources: list[dict]) -> dict[str, str]:
    """``{resource name: dtype}`` of what a golden frame stores: inputs, boundary buffers, the output."""
    out = input_dtypes(resources)
    out.update({r["name"]: FORMAT_DTYPES["boundary"] for r in resources if r["role"] == "boundary"})
    out.update({r["name"]: FORMAT_DTYPES[r["format"]] for r in resources if r["role"] == "output"})
    return out


def run_golden(plan: dict, frames: list[dict], tflite: bytes, profile: str, scale: int) -> list[GoldenFrame]:
    """Run ``frames`` (numpy frames, first one treated as a reset) through the bundle ``plan``'s schedule."""
    from ..quantize.runtime import TfliteRunner

    if get_runtime(profile).engine != "litert":
        raise ValueError(f"golden frames need a LiteRT runtime ({', '.join(runtime_names('litert'))}), got {profile!r}")
    litert = TfliteRunner(tflite, profile)

    def npu(step, feeds):
        (name, array), = feeds.items()
        return {next(iter(step["outputs"])): next(iter(litert.run([array]).values()))}

    runner = ScheduleRunner(plan["resources"], plan["schedule"], dict(plan["weights"]), ReferencePasses(), npu, profile, scale)
    kept = golden_arrays(plan["resources"])
    out = []
    for t, frame in enumerate(frames):
        reset = frame["reset"] or t == 0
        inputs = {k: frame[k] for k in runner.inputs}
        runner.run_frame(inputs, frame["jitter"], reset)
        values = {**runner.values, **inputs}  # the inputs as filled (end_of_frame may swap their resources)
        arrays = {k: np.ascontiguousarray(values[k], dtype) for k, dtype in kept.items()}
        out.append(GoldenFrame(np.asarray(frame["jitter"], np.float32), reset, arrays))
    return out


def write_golden(root: Path, frames: list[GoldenFrame], scale: int, jitter_table: list[dict]) -> list[dict]:
    """Write each frame's arrays under ``root/golden/frame_NNN/``; returns the manifest's frame entries."""
    entries = []
    for t, frame in enumerate(frames):
        folder = Path("golden") / f"frame_{t:03d}"
        (root / folder).mkdir(parents=True, exist_ok=True)
        arrays = {}
        for key, array in frame.arrays.items():
            name = (folder / f"{key}.bin").as_posix()
            data = array.astype(array.dtype.newbyteorder("<"), copy=False)
            (root / name).write_bytes(data.tobytes())
            arrays[key] = {"file": name, "dtype": array.dtype.name, "shape": list(array.shape)}
        entries.append({**frame_entry(t, frame.reset, frame.jitter, scale, jitter_table), "arrays": arrays})
    return entries


def frame_entry(index: int, reset: bool, jitter: np.ndarray, scale: int, jitter_table: list[dict]) -> dict:
    """A frame's manifest entry: reset, jitter (LR pixels), sampled sub-pixel, its jitter table entry (or None)."""
    jitter = np.asarray(jitter, np.float32)
    return {
        "index": index,
        "reset": bool(reset),
        "jitter": [float(v) for v in jitter],
        "subpixel": [int(v) for v in subpixel_index(jitter, scale)],
        "jitter_index": _table_index(jitter, jitter_table),
    }


def _table_index(jitter: np.ndarray, table: list[dict]) -> int | None:
    """Index of the jitter table entry equal (as float32) to ``jitter``, or None."""
    for entry in table:
        if np.array_equal(np.float32(entry["offset"]), np.float32(jitter)):
            return entry["index"]
    return None


def tolerance_of(manifest: dict, key: str) -> int:
    """Golden tolerance of array ``key`` (LSB or display codes, ``TOLERANCES`` keys in the manifest); 0 for inputs."""
    roles = {r["name"]: r["role"] for r in manifest["resources"]}
    tolerances = manifest["golden"]["tolerances"]
    if roles.get(key) == "output":
        return int(tolerances.get("display_codes", 0))
    for b in manifest["boundary"]:
        if b["buffer"]["resource"] == key:
            return int(tolerances.get("npu_input_lsb" if b["direction"] == "gpu->npu" else "npu_output_lsb", 0))
    return 0


def golden_mismatch(manifest: dict, index: int, got: dict[str, np.ndarray], want: dict[str, np.ndarray]) -> str | None:
    """What differs between a replay of golden frame ``index`` and its stored arrays beyond the
    manifest's tolerances (``"npu_output: 2000 of 9216 values (max 255)"``, one clause per array), or None."""
    clauses = []
    for key, expected in want.items():
        if key not in got:
            continue
        actual = np.asarray(got[key]).astype(np.float64).reshape(expected.shape)
        diff = np.abs(actual - expected.astype(np.float64))
        beyond = int(np.count_nonzero(diff > tolerance_of(manifest, key)))
        if beyond:
            clauses.append(f"{key} {beyond} of {diff.size} values (max {diff.max():g})")
    return ", ".join(clauses) or None
