"""Read a bundle back: the manifest, the golden arrays, and the GPU weights from the bundle alone.

:func:`open_bundle` verifies the bundle (:func:`.check.check_bundle`) before anything is read, so
a reader never runs a bundle whose files differ from what the manifest promises.  The GPU weight
blocks are unpacked (the inverse of :func:`mnss_kit.gpu.weights.pack_conv3x3`), so the desktop
emulator can run the manifest's schedule (:mod:`mnss_kit.gpu.interpret`) without the checkpoint.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..gpu.weights import Conv3x3, layers_of
from .check import check_bundle
from .manifest import read_manifest


def unpack_conv3x3(packed: np.ndarray, out_channels: int, in_channels: int) -> Conv3x3:
    """``(rows, 4)`` float32 in the ``conv3x3.glsl`` layout -> the conv's ``(Cout, Cin, 3, 3)`` weights and ``(Cout,)`` bias."""
    out_layers, in_layers = layers_of(out_channels), layers_of(in_channels)
    packed = np.asarray(packed, np.float32)
    expected = out_layers + out_layers * 9 * in_layers * 4
    if packed.shape != (expected, 4):
        raise ValueError(f"packed conv has shape {packed.shape}, {out_channels} <- {in_channels} channels need ({expected}, 4)")
    bias = packed[:out_layers].reshape(-1)[:out_channels]
    # rows (og, ky, kx, il, k) of 4 outputs o4 -> (og, o4, il, k, ky, kx)
    blocks = packed[out_layers:].reshape(out_layers, 3, 3, in_layers, 4, 4).transpose(0, 5, 3, 4, 1, 2)
    weight = blocks.reshape(out_layers * 4, in_layers * 4, 3, 3)[:out_channels, :in_channels]
    return Conv3x3(np.ascontiguousarray(weight), np.ascontiguousarray(bias))


@dataclass
class Bundle:
    root: Path
    manifest: dict

    def read(self, name: str) -> bytes:
        return (self.root / name).read_bytes()

    def npu_model(self) -> bytes:
        """``npu.tflite`` bytes."""
        return self.read(self.manifest["npu"]["model"])

    def golden(self, index: int) -> dict[str, np.ndarray]:
        """Arrays of golden frame ``index`` (shapes and dtypes from the manifest)."""
        frame = self.manifest["golden"]["frames"][index]
        out = {}
        for key, entry in frame["arrays"].items():
            dtype = np.dtype(entry["dtype"]).newbyteorder("<")
            out[key] = np.frombuffer(self.read(entry["file"]), dtype=dtype).reshape(entry["shape"]).astype(dtype.newbyteorder("="))
        return out

    def golden_inputs(self, index: int) -> dict:
        """Golden frame ``index``'s inputs: every ``input`` resource as float32, ``jitter`` and ``reset``."""
        entry = self.manifest["golden"]["frames"][index]
        arrays = self.golden(index)
        out = {name: arrays[name].astype(np.float32) for name in input_names(self.manifest)}
        return {**out, "jitter": np.asarray(entry["jitter"], np.float32), "reset": entry["reset"]}

    def gpu_weights(self) -> dict[str, Conv3x3]:
        """Every learned GPU conv by block name, unpacked from ``gpu_weights.bin``."""
        weights = self.manifest["gpu"]["weights"]
        data = self.read(weights["file"])
        convs = {}
        for block in weights["blocks"]:
            raw = np.frombuffer(data[block["offset"]:block["offset"] + block["bytes"]], dtype="<f4").reshape(block["shape"])
            convs[block["name"]] = unpack_conv3x3(raw, block["conv"]["out_channels"], block["conv"]["in_channels"])
        return convs


def open_bundle(path: str | Path, verify: bool = True) -> Bundle:
    """A bundle, after ``bundle check`` (``UserError`` naming the first problem) unless ``verify`` is False."""
    root = Path(path)
    manifest = read_manifest(root)
    if verify:
        problems = check_bundle(root)
        if problems:
            more = f" (and {len(problems) - 1} more; run `mnss-kit bundle check`)" if len(problems) > 1 else ""
            raise UserError(f"{root}: {problems[0]}{more}")
    return Bundle(root, manifest)


def input_names(manifest: dict) -> list[str]:
    """Names of the resources the engine fills each frame (``role: input``), in manifest order."""
    return [r["name"] for r in manifest["resources"] if r["role"] == "input"]
