"""The operators an int8 NPU graph (``npu.tflite``) can hold: one table every stage asks.

``quantize.tflite_writer`` writes these ops at these versions, ``emulate.npu_graph`` reads and
the numpy interpreter runs them, ``split`` calls a stage NPU-eligible only if every op it needs
is here, and each device profile (``mnss_kit/configs/devices/*.yaml``) lists which of them its NPU
accepts (checked on load).  ``quantize.trace`` maps PyTorch modules onto them; the torch
constructs it accepts are in its docstring.

Data only (no imports beyond the standard library).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class NpuOp:
    """One TFLite builtin operator of the int8 NPU graph."""

    builtin: str  # TFLite BuiltinOperator name
    version: int  # op version written for int8 activations: the lowest that covers int8
    version_int16: int  # op version written when int16 activations are involved
    activation_inputs: int | None  # non-constant inputs, constants follow them (None: any number)
    options: str | None  # TFLite BuiltinOptions member holding its parameters (None: no options)


# DEPTH_TO_SPACE stays at version 1: LiteRT's reference resolver accepts no other.
NPU_OPS: dict[str, NpuOp] = {
    op.builtin: op
    for op in (
        NpuOp("CONV_2D", 3, 4, 1, "Conv2DOptions"),
        NpuOp("DEPTHWISE_CONV_2D", 3, 5, 1, "DepthwiseConv2DOptions"),
        NpuOp("ADD", 2, 3, 2, "AddOptions"),
        NpuOp("MUL", 2, 4, 2, "MulOptions"),
        NpuOp("CONCATENATION", 2, 3, None, "ConcatenationOptions"),
        NpuOp("LOGISTIC", 2, 3, 1, None),
        NpuOp("TANH", 2, 3, 1, None),
        NpuOp("AVERAGE_POOL_2D", 2, 3, 1, "Pool2DOptions"),
        NpuOp("RESIZE_BILINEAR", 3, 4, 1, "ResizeBilinearOptions"),
        NpuOp("DEPTH_TO_SPACE", 1, 1, 1, "DepthToSpaceOptions"),
        NpuOp("SPACE_TO_DEPTH", 2, 2, 1, "SpaceToDepthOptions"),
        NpuOp("PAD", 2, 4, 1, "PadOptions"),
        NpuOp("QUANTIZE", 2, 4, 1, None),
        NpuOp("DEQUANTIZE", 2, 4, 1, None),
    )
}
