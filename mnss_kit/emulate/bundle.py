"""What the frame loop reads from a bundle, from the bundle's files alone.

:func:`mnss_kit.export.reader.open_bundle` verifies the whole bundle first (``bundle check``:
every file present with its size and SHA-256, the manifest's NPU tensors against ``npu.tflite``
and ``npu_qdq.onnx``, the schedule) and unpacks the GPU weights; a problem is a one-line
``UserError`` naming the file or tensor.  This module adds the NPU graph the emulator interprets
(``npu.tflite`` parsed op by op, refusing operators it does not implement) and checks that the
tensors the schedule exchanges with the NPU are the graph's inputs and outputs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import UserError
from ..gpu.weights import Conv3x3
from .npu_graph import NpuGraph, read_npu_graph


@dataclass
class BundleSpec:
    """Everything the frame loop reads from a bundle.  ``lr_size`` is (width, height)."""

    source: str
    graph: NpuGraph
    tflite: bytes
    onnx: bytes | None
    manifest: dict
    weights: dict[str, Conv3x3]

    @property
    def scale(self) -> int | float:
        """2, 3, 4, or a quality mode such as 1.5 (a fractional bundle's sizes are ``lr_size``, ``hr_size``)."""
        value = self.manifest["scale"]
        return int(value) if float(value).is_integer() else float(value)

    @property
    def hr_size(self) -> tuple[int, int]:
        w, h = self.manifest["hr_size"]
        return int(w), int(h)

    @property
    def lr_size(self) -> tuple[int, int]:
        w, h = self.manifest["lr_size"]
        return int(w), int(h)

    @property
    def profile(self) -> str:
        """Numerics profile the bundle's NPU-input quantization and golden frames follow."""
        return self.manifest["golden"]["profile"]

    def resources(self, role: str) -> list[dict]:
        return [r for r in self.manifest["resources"] if r["role"] == role]

    def boundary(self, direction: str) -> dict:
        """The boundary entry crossing ``gpu->npu`` or ``npu->gpu``."""
        return next(b for b in self.manifest["boundary"] if b["direction"] == direction)


def read_bundle(path: str | Path) -> BundleSpec:
    """Open and verify the bundle directory ``path``; ``UserError`` naming the file or tensor on any problem."""
    from ..export.reader import open_bundle

    bundle = open_bundle(path)
    m = bundle.manifest
    root = Path(path)
    tflite = bundle.npu_model()
    graph = read_npu_graph(tflite, source=str(root / m["npu"]["model"]))
    fed = [t for s in m["schedule"]["steps"] if s["kind"] == "npu" for t in s["inputs"]]
    read = [t for s in m["schedule"]["steps"] if s["kind"] == "npu" for t in s["outputs"]]
    if graph.inputs != fed or graph.outputs != read:
        raise UserError(f"{graph.source}: inputs {graph.inputs} and outputs {graph.outputs}; the schedule exchanges "
                        f"{fed} and {read} with the GPU stage")
    for b in m["boundary"]:
        if list(graph.tensors[b["tensor"]].shape) != list(b["shape"]):
            raise UserError(f"tensor '{b['tensor']}': shape {list(graph.tensors[b['tensor']].shape)} in {graph.source}, "
                            f"the GPU stage exchanges {list(b['shape'])}")
    onnx = bundle.read(m["npu"]["onnx"]) if m["npu"].get("onnx") else None
    return BundleSpec(str(root), graph, tflite, onnx, m, bundle.gpu_weights())
