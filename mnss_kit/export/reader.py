"""Read a bundle back: the manifest, the golden arrays, and the GPU stage rebuilt from the bundle alone.

:func:`open_bundle` verifies the bundle (:func:`.check.check_bundle`) before anything is read, so
a reader never runs a bundle whose files differ from what the manifest promises.  The GPU weight
blocks are unpacked (the inverse of :func:`mnss_kit.gpu.weights.pack_conv3x3`) into the same
:class:`~mnss_kit.gpu.schedule.GpuStage` the exporter packed, so the desktop emulator can run
:mod:`mnss_kit.gpu.schedule` on a bundle without the checkpoint.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..gpu.schedule import GpuStage, NpuBoundary
from ..gpu.weights import Conv3x3, GpuWeights, layers_of
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

    def golden_frame(self, index: int) -> dict:
        """Golden frame ``index`` as the numpy frame :mod:`mnss_kit.gpu.schedule` takes (inputs only)."""
        entry = self.manifest["golden"]["frames"][index]
        arrays = self.golden(index)
        return {"color": arrays["color"].astype(np.float32), "depth": arrays["depth"], "motion": arrays["motion"],
                "jitter": np.asarray(entry["jitter"], np.float32), "reset": entry["reset"]}

    def gpu_stage(self) -> GpuStage:
        """The GPU stage (config knobs and unpacked weights) from the manifest and ``gpu_weights.bin``."""
        weights = self.manifest["gpu"]["weights"]
        data = self.read(weights["file"])
        convs = {}
        for block in weights["blocks"]:
            raw = np.frombuffer(data[block["offset"]:block["offset"] + block["bytes"]], dtype="<f4").reshape(block["shape"])
            convs[block["name"]] = unpack_conv3x3(raw, block["conv"]["out_channels"], block["conv"]["in_channels"])
        aa = tuple(convs[name] for name in sorted((n for n in convs if n.startswith("aa.")), key=lambda n: int(n.split(".")[1])))
        config = self.manifest["model"]["config"]
        return GpuStage(
            scale=self.manifest["scale"],
            with_history=config["history"] == "output",
            activation=config["inpaint_activation"],
            weight_upsample=config["weight_upsample"],
            enhance_beta=config["enhance_beta"] if config["enhance"] else None,
            weights=GpuWeights(convs.get("inpaint"), aa),
        )

    def boundary(self) -> NpuBoundary:
        """Scales and zero points of the NPU input and output, and the golden frames' numerics profile."""
        by_role = {b["role"]: b for b in self.manifest["boundary"]}
        i, o = by_role["npu_input"], by_role["npu_output"]
        return NpuBoundary(i["scale"], i["zero_point"], o["scale"], o["zero_point"], self.manifest["golden"]["profile"])


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
