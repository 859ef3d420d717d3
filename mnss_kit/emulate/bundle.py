"""What the frame loop reads from a bundle, from the bundle's files alone.

:func:`mnss_kit.export.reader.open_bundle` verifies the whole bundle first (``bundle check``:
every file present with its size and SHA-256, the manifest's NPU tensors against ``npu.tflite``
and ``npu_qdq.onnx``, the schedule) and rebuilds the GPU stage from the manifest and the weight
file; a problem is a one-line ``UserError`` naming the file or tensor.  This module adds the NPU
graph the emulator interprets (``npu.tflite`` parsed op by op, refusing operators it does not
implement) and the names of the two tensors crossing the GPU/NPU boundary.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import UserError
from ..gpu.schedule import GpuStage, NpuBoundary
from .npu_graph import NpuGraph, read_npu_graph


@dataclass
class BundleSpec:
    """Everything the frame loop reads from a bundle.  ``lr_size`` is (width, height); ``manifest``
    is None for a bundle assembled in memory (tests)."""

    source: str
    graph: NpuGraph
    tflite: bytes
    onnx: bytes | None
    stage: GpuStage
    boundary: NpuBoundary
    npu_input: str
    npu_output: str
    lr_size: tuple[int, int]
    manifest: dict | None = None


def read_bundle(path: str | Path) -> BundleSpec:
    """Open and verify the bundle directory ``path``; ``UserError`` naming the file or tensor on any problem."""
    from ..export.reader import open_bundle

    bundle = open_bundle(path)
    m = bundle.manifest
    root = Path(path)
    tflite = bundle.npu_model()
    graph = read_npu_graph(tflite, source=str(root / m["npu"]["model"]))
    roles = {b["role"]: b["tensor"] for b in m["boundary"]}
    npu_input, npu_output = roles.get("npu_input"), roles.get("npu_output")
    if graph.inputs != [npu_input] or graph.outputs != [npu_output]:
        raise UserError(f"{graph.source}: inputs {graph.inputs} and outputs {graph.outputs}; the emulator exchanges one "
                        f"input ('{npu_input}') and one output ('{npu_output}') with the GPU stage")
    stage = bundle.gpu_stage()
    lr_size = (int(m["lr_size"][0]), int(m["lr_size"][1]))
    expected = (1, lr_size[1] * stage.scale, lr_size[0] * stage.scale, 3)
    for name in (npu_input, npu_output):
        if graph.tensors[name].shape != expected:
            raise UserError(f"tensor '{name}': shape {list(graph.tensors[name].shape)} in {graph.source}, "
                            f"the GPU stage exchanges {list(expected)}")
    onnx = bundle.read(m["npu"]["onnx"]) if m["npu"].get("onnx") else None
    return BundleSpec(str(root), graph, tflite, onnx, stage, bundle.boundary(), npu_input, npu_output, lr_size, m)
