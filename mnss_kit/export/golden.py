"""Golden frames: a few consecutive frames through the desktop reference, for an on-device self-test.

The GPU passes run as their numpy reference (:class:`mnss_kit.gpu.reference.ReferencePasses`,
the emulator's GPU stage, fp16 storage rounding included) and the NPU graph in LiteRT with the
kernel set of a named numerics profile, so every stored value is reproducible on a desk.  Per
frame the bundle keeps the inputs exactly as the input textures hold them and the tensors a
phone can read back: the packed NPU input, the NPU output and the display codes.

Arrays are raw little-endian files, C order, shape and dtype in the manifest:

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

from ..gpu.reference import ReferencePasses
from ..gpu.schedule import GpuStage, NpuBoundary, after_npu, before_npu, next_state
from ..ops.jitter import subpixel_index
from ..ops.runtimes import get_runtime, runtime_names

ARRAY_DTYPES = {"color": "float16", "depth": "float32", "motion": "float32", "npu_input": "int8", "npu_output": "int8", "display": "uint8"}
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


def frame_from_torch(frame: dict) -> dict:
    """A loader frame (batched NCHW torch tensors) -> the numpy frame ``gpu.schedule`` takes."""

    def hwc(key):
        return np.ascontiguousarray(frame[key][0].permute(1, 2, 0).numpy(), dtype=np.float32)

    reset = frame.get("reset")
    return {
        "color": hwc("color"),
        "depth": hwc("depth"),
        "motion": hwc("motion"),
        "jitter": np.asarray(frame["jitter"][0].numpy(), np.float32),
        "reset": bool(reset is not None and float(reset[0]) > 0.5),
    }


def run_golden(stage: GpuStage, frames: list[dict], tflite: bytes, boundary: NpuBoundary) -> list[GoldenFrame]:
    """Run ``frames`` (numpy frames, first one treated as a reset) through the reference pipeline."""
    from ..quantize.runtime import TfliteRunner

    if get_runtime(boundary.profile).engine != "litert":
        raise ValueError(f"golden frames need a LiteRT runtime ({', '.join(runtime_names('litert'))}), got {boundary.profile!r}")
    runner = TfliteRunner(tflite, boundary.profile)
    passes = ReferencePasses()
    state, out = None, []
    for t, frame in enumerate(frames):
        frame = dict(frame, reset=frame["reset"] or t == 0)
        npu_input = before_npu(passes, stage, frame, state, boundary)["npu_input"]
        npu_output = next(iter(runner.run([npu_input]).values()))
        history, display = after_npu(passes, stage, npu_output, boundary)
        state = next_state(frame, history)
        arrays = {
            "color": frame["color"].astype(np.float16),
            "depth": frame["depth"],
            "motion": frame["motion"],
            "npu_input": npu_input,
            "npu_output": npu_output,
            "display": display,
        }
        out.append(GoldenFrame(np.asarray(frame["jitter"], np.float32), frame["reset"], {k: np.ascontiguousarray(v, ARRAY_DTYPES[k]) for k, v in arrays.items()}))
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
            arrays[key] = {"file": name, "dtype": ARRAY_DTYPES[key], "shape": list(array.shape)}
        sub = [int(v) for v in subpixel_index(frame.jitter, scale)]
        entries.append({
            "index": t,
            "reset": frame.reset,
            "jitter": [float(v) for v in frame.jitter],
            "subpixel": sub,
            "jitter_index": _table_index(frame.jitter, jitter_table),
            "arrays": arrays,
        })
    return entries


def _table_index(jitter: np.ndarray, table: list[dict]) -> int | None:
    """Index of the jitter table entry equal (as float32) to ``jitter``, or None."""
    for entry in table:
        if np.array_equal(np.float32(entry["offset"]), np.float32(jitter)):
            return entry["index"]
    return None
