"""Kernel sets the emulator reproduces: which formula each int8 op uses, as data.

A kernel set names one runtime's CPU kernels.  Its fields pick formulas
defined once in ``mnss_kit.ops.quant`` (requantization profiles) and
``mnss_kit.ops.quant_ops`` (ADD, MUL, pooling, resize, requantize); the
kernels in ``emulate.kernels`` read these fields and never branch on the
kernel set's name.  Every entry was checked bit for bit against
ai-edge-litert 2.3.0 (x86-64) by tests/emulate.
"""

from __future__ import annotations

from dataclasses import dataclass


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
        Formula names of ``ops.quant_ops``.
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
        add="float32",
        mul="float32",
        average_pool="tflite",
        resize_bilinear="xnnpack_q11",
        quantize="xnnpack",
        dequantize="exact",
        requantize="xnnpack_q8",
        description="XNNPACK delegate (OpResolverType.AUTO), builtin kernels for ops it does not take",
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
