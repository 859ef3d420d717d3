"""Kernel sets the emulator reproduces: which formula each int8 op uses, as data.

A kernel set names one runtime's CPU kernels.  Its fields are formula names defined once in
``mnss_kit.ops.quant`` (requantization profiles: ``quant.PROFILES``) and
``mnss_kit.ops.quant_ops`` (``quant_ops.FORMULAS`` per op; a profile name there means the
``ops.quant`` definition under that profile), checked when the set is built.  The kernels in
``emulate.kernels`` read these fields and never branch on the kernel set's name.  Every entry
was checked bit for bit against its runtime on x86-64 by tests/emulate (ai-edge-litert 2.3.0,
onnxruntime 1.31).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..ops import quant, quant_ops

# KernelSet field -> quant_ops.FORMULAS key of the op it chooses the formula of
_OP_FIELDS = {"add": "ADD", "mul": "MUL", "average_pool": "AVERAGE_POOL_2D", "resize_bilinear": "RESIZE_BILINEAR",
              "quantize": "QUANTIZE", "dequantize": "DEQUANTIZE", "requantize": "REQUANTIZE"}
_PROFILE_FIELDS = ("numerics", "depthwise_numerics", "depthwise_tail_numerics")


@dataclass(frozen=True)
class KernelSet:
    """Formulas of one runtime's int8 kernels.

    numerics
        ``ops.quant`` profile for CONV_2D requantization, QUANTIZE (float ->
        int8) and table building (LOGISTIC, TANH).
    depthwise_numerics, depthwise_vector_channels, depthwise_tail_numerics
        DEPTHWISE_CONV_2D requantization.  With ``depthwise_vector_channels``
        ``v > 0`` the first ``C // v * v`` output channels use
        ``depthwise_numerics`` and the remaining ones ``depthwise_tail_numerics``
        (LiteRT's optimized output stage handles 8 channels per vector step and
        the rest with the scalar reference code).
    add, mul, average_pool, resize_bilinear, quantize, dequantize, requantize
        Formula names of ``ops.quant_ops`` (``quant_ops.FORMULAS``).
    """

    name: str
    resolver: str | None  # LiteRT op resolver running this kernel set, None if not LiteRT
    numerics: str
    depthwise_numerics: str
    depthwise_vector_channels: int
    depthwise_tail_numerics: str
    add: str
    mul: str
    average_pool: str
    resize_bilinear: str
    quantize: str
    dequantize: str
    requantize: str
    description: str

    def __post_init__(self):
        for name in _PROFILE_FIELDS:
            quant.get_profile(getattr(self, name))  # ValueError on an unknown profile
        for name, op in _OP_FIELDS.items():
            quant_ops.check_formula(op, getattr(self, name))

    def formula(self, op: str) -> str:
        """The formula name this set uses for ``op`` (a ``quant_ops.FORMULAS`` key, e.g. ``"ADD"``)."""
        return getattr(self, next(name for name, kind in _OP_FIELDS.items() if kind == op))


KERNEL_SETS: dict[str, KernelSet] = {
    "tflite_reference": KernelSet(
        name="tflite_reference",
        resolver="BUILTIN_REF",
        numerics="tflite_reference",
        depthwise_numerics="tflite_reference",
        depthwise_vector_channels=0,
        depthwise_tail_numerics="tflite_reference",
        add="tflite_reference",
        mul="tflite",
        average_pool="tflite",
        resize_bilinear="tflite",
        quantize="tflite_reference",
        dequantize="exact",
        requantize="tflite_reference",
        description="LiteRT reference kernels (OpResolverType.BUILTIN_REF)",
    ),
    "tflite_optimized": KernelSet(
        name="tflite_optimized",
        resolver="BUILTIN_WITHOUT_DEFAULT_DELEGATES",
        numerics="tflite_optimized",
        depthwise_numerics="tflite_optimized",
        depthwise_vector_channels=8,
        depthwise_tail_numerics="tflite_reference",
        add="tflite_neon16",
        mul="tflite",
        average_pool="tflite",
        resize_bilinear="tflite",
        quantize="tflite_neon8",
        dequantize="tflite_neon8",
        requantize="tflite_neon16",
        description="LiteRT optimized builtin kernels (OpResolverType.BUILTIN_WITHOUT_DEFAULT_DELEGATES)",
    ),
    "xnnpack": KernelSet(
        name="xnnpack",
        resolver="AUTO",
        numerics="xnnpack",
        depthwise_numerics="xnnpack",
        depthwise_vector_channels=0,
        depthwise_tail_numerics="xnnpack",
        add="xnnpack",
        mul="xnnpack",
        average_pool="tflite",
        resize_bilinear="xnnpack_q11",
        quantize="xnnpack",
        dequantize="exact",
        requantize="xnnpack_q8",
        description="XNNPACK delegate (OpResolverType.AUTO), builtin kernels for ops it does not take",
    ),
    "onnxruntime": KernelSet(
        name="onnxruntime",
        resolver=None,
        numerics="onnxruntime",
        depthwise_numerics="onnxruntime",
        depthwise_vector_channels=0,
        depthwise_tail_numerics="onnxruntime",
        add="onnxruntime",
        mul="onnxruntime",
        average_pool="onnxruntime",
        resize_bilinear="onnxruntime",
        quantize="onnxruntime",
        dequantize="exact",
        requantize="onnxruntime",
        description="ONNX Runtime CPU execution provider on npu_qdq.onnx with its QDQ groups fused to "
                    "QLinear kernels (QLinearConv, QLinearAdd, QLinearMul, QLinearAveragePool, QLinearSigmoid)",
    ),
}


def get_kernel_set(kernel_set: str | KernelSet) -> KernelSet:
    """A :class:`KernelSet` by name (or the set itself)."""
    if isinstance(kernel_set, KernelSet):
        return kernel_set
    try:
        return KERNEL_SETS[kernel_set]
    except KeyError:
        raise ValueError(f"unknown kernel set {kernel_set!r} (one of: {', '.join(KERNEL_SETS)})") from None
