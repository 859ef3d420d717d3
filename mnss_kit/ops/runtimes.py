"""The runtimes whose int8 arithmetic the toolkit reproduces bit for bit: one table, one name each.

Every command, file and test names a runtime by its key in :data:`RUNTIMES`:

``tflite-ref``      LiteRT reference kernels (``OpResolverType.BUILTIN_REF``).
``tflite-builtin``  LiteRT optimized builtin kernels (``BUILTIN_WITHOUT_DEFAULT_DELEGATES``).
``xnnpack``         LiteRT's default, the XNNPACK delegate (``AUTO``); builtin kernels for the
                    ops XNNPACK declines.
``ort-cpu``         ONNX Runtime CPU execution provider on ``npu_qdq.onnx`` (MLAS, QDQ groups
                    fused to int8 QLinear kernels, which give the same integers with and
                    without VNNI: docs/emulator.md).

A :class:`Runtime` is plain data: how to start it (the engine and, for LiteRT, the op
resolver) and, per int8 op, the one formula it uses.  The formulas are defined once in
``mnss_kit.ops.int8``, one module per op (its docstring maps op to file); those functions read
a runtime's fields and never branch on its name.  Starting a runtime needs ``ai_edge_litert`` or ``onnxruntime`` and lives in
``quantize.runtime`` and ``emulate.npu``, keyed by these names.  Every entry was checked bit for
bit against its runtime on x86-64 (ai-edge-litert 2.3.0, onnxruntime 1.31) by
tests/quantize/test_profiles.py and tests/emulate.

Two things a reader would not guess about ``tflite-builtin``: on x86 it is LiteRT's ARM NEON
code compiled through an SSE emulation of the intrinsics, and its vector loops (16 values for
ADD and int8 -> int8 QUANTIZE, 8 for float QUANTIZE and DEQUANTIZE, 8 output channels for the
depthwise output stage) round differently from the scalar tail that finishes a tensor, so where
a value sits decides its rounding.  Its ``quantize_*`` fields are the rounding of the vector
body; the ``tflite_neon8`` QUANTIZE formula adds the tail.

This module holds names and data only (no imports beyond the standard library) so that
``--help`` stays light.
"""

from __future__ import annotations

from dataclasses import dataclass

ENGINES = ("litert", "onnxruntime")
ROUNDINGS = ("away_from_zero", "half_up", "half_even")
# ADD methods of ops.int8.add.add; the vector formula tflite_neon16 of ops.int8.vector.add combines two of them
ADD_METHODS = ("q31_double_round", "q31_single_round_inputs", "xnnpack_fixed_point", "float32_fma")
# formula names per op (ops.int8); "scalar" means every value by the runtime's own rounding fields
FORMULAS: dict[str, tuple[str, ...]] = {
    "ADD": ADD_METHODS + ("tflite_neon16",),
    "MUL": ("tflite", "xnnpack", "onnxruntime"),
    "AVERAGE_POOL_2D": ("tflite", "onnxruntime"),
    "RESIZE_BILINEAR": ("tflite", "xnnpack_q11", "onnxruntime"),
    "QUANTIZE": ("scalar", "tflite_neon8"),
    "DEQUANTIZE": ("exact", "tflite_neon8"),
    "REQUANTIZE": ("scalar", "tflite_neon16", "xnnpack_q8", "onnxruntime"),
}
# Runtime field -> the op whose formula it names
OP_FIELDS = {"add": "ADD", "mul": "MUL", "average_pool": "AVERAGE_POOL_2D", "resize_bilinear": "RESIZE_BILINEAR",
             "quantize": "QUANTIZE", "dequantize": "DEQUANTIZE", "requantize": "REQUANTIZE"}
_ROUNDING_FIELDS = ("shift_rounding", "float_rounding", "quantize_rounding", "table_rounding")


@dataclass(frozen=True)
class Runtime:
    """One runtime: how it is started and the formula of each of its int8 ops.

    engine, litert_resolver
        ``"litert"`` with an ``OpResolverType`` member name, or ``"onnxruntime"`` (no resolver).
    multiplier, shift_rounding, float_rounding
        CONV_2D requantization (``ops.int8.requantize.requantize``).  ``multiplier`` ``"q31"``: integer
        mantissa and shift (TFLite ``QuantizeMultiplier``), the high multiply then a right shift
        rounded by ``shift_rounding`` (``away_from_zero`` = gemmlowp ``RoundingDivideByPOT``,
        ``half_up`` = ``(x + 2^(n-1)) >> n``).  ``"float32"``: one float32 scale per channel,
        ``float32(acc) * scale`` rounded by ``float_rounding``.
    depthwise_vector_channels, depthwise_tail
        DEPTHWISE_CONV_2D requantization.  With ``v > 0`` the first ``C // v * v`` output channels
        use this runtime's CONV_2D rule and the rest the rule of the runtime ``depthwise_tail``.
    quantize_reciprocal, quantize_rounding
        float32 -> integer (``ops.int8.quantize.quantize``): ``x * (1 / scale)`` in float32 instead of
        ``x / scale``, and the tie rule.  The GPU pass that packs the NPU input rounds this way.
    table_rounding
        Rounding of the 256-entry LOGISTIC and TANH tables built in float32.
    add, mul, average_pool, resize_bilinear, quantize, dequantize, requantize
        Formula names (:data:`FORMULAS` of the op in :data:`OP_FIELDS`).
    """

    name: str
    description: str
    engine: str
    litert_resolver: str | None
    multiplier: str
    shift_rounding: str
    float_rounding: str
    depthwise_vector_channels: int
    depthwise_tail: str
    quantize_reciprocal: bool
    quantize_rounding: str
    table_rounding: str
    add: str
    mul: str
    average_pool: str
    resize_bilinear: str
    quantize: str
    dequantize: str
    requantize: str

    def __post_init__(self):
        if self.engine not in ENGINES or (self.engine == "litert") != (self.litert_resolver is not None):
            raise ValueError(f"runtime {self.name!r}: engine {self.engine!r} with resolver {self.litert_resolver!r}")
        if self.multiplier not in ("q31", "float32"):
            raise ValueError(f"runtime {self.name!r}: unknown multiplier {self.multiplier!r}")
        for name in _ROUNDING_FIELDS:
            if getattr(self, name) not in ROUNDINGS:
                raise ValueError(f"runtime {self.name!r}: unknown {name} {getattr(self, name)!r}")
        for name, op in OP_FIELDS.items():
            check_formula(op, getattr(self, name))

    def formula(self, op: str) -> str:
        """The formula this runtime uses for ``op`` (a :data:`FORMULAS` key, e.g. ``"ADD"``)."""
        return getattr(self, next(name for name, kind in OP_FIELDS.items() if kind == op))


def check_formula(op: str, formula: str) -> None:
    """``ValueError`` unless ``formula`` is one of ``FORMULAS[op]``."""
    if formula not in FORMULAS[op]:
        raise ValueError(f"unknown {op} formula {formula!r} (one of: {', '.join(FORMULAS[op])})")


RUNTIMES: dict[str, Runtime] = {
    "tflite-ref": Runtime(
        name="tflite-ref",
        description="LiteRT reference kernels (OpResolverType.BUILTIN_REF)",
        engine="litert", litert_resolver="BUILTIN_REF",
        multiplier="q31", shift_rounding="away_from_zero", float_rounding="away_from_zero",
        depthwise_vector_channels=0, depthwise_tail="tflite-ref",
        quantize_reciprocal=False, quantize_rounding="away_from_zero", table_rounding="away_from_zero",
        add="q31_double_round", mul="tflite", average_pool="tflite", resize_bilinear="tflite",
        quantize="scalar", dequantize="exact", requantize="scalar",
    ),
    "tflite-builtin": Runtime(
        name="tflite-builtin",
        description="LiteRT optimized builtin kernels (OpResolverType.BUILTIN_WITHOUT_DEFAULT_DELEGATES)",
        engine="litert", litert_resolver="BUILTIN_WITHOUT_DEFAULT_DELEGATES",
        multiplier="q31", shift_rounding="half_up", float_rounding="away_from_zero",
        depthwise_vector_channels=8, depthwise_tail="tflite-ref",
        quantize_reciprocal=True, quantize_rounding="half_even", table_rounding="away_from_zero",
        add="tflite_neon16", mul="tflite", average_pool="tflite", resize_bilinear="tflite",
        quantize="tflite_neon8", dequantize="tflite_neon8", requantize="tflite_neon16",
    ),
    "xnnpack": Runtime(
        name="xnnpack",
        description="LiteRT default, the XNNPACK delegate (OpResolverType.AUTO); builtin kernels for ops it does not take",
        engine="litert", litert_resolver="AUTO",
        multiplier="float32", shift_rounding="half_even", float_rounding="half_even",
        depthwise_vector_channels=0, depthwise_tail="xnnpack",
        quantize_reciprocal=True, quantize_rounding="half_even", table_rounding="half_even",
        add="xnnpack_fixed_point", mul="xnnpack", average_pool="tflite", resize_bilinear="xnnpack_q11",
        quantize="scalar", dequantize="exact", requantize="xnnpack_q8",
    ),
    "ort-cpu": Runtime(
        name="ort-cpu",
        description="ONNX Runtime CPU execution provider on npu_qdq.onnx with its QDQ groups fused to QLinear "
                    "kernels (QLinearConv, QLinearAdd, QLinearMul, QLinearAveragePool, QLinearSigmoid), x86-64 with FMA",
        engine="onnxruntime", litert_resolver=None,
        multiplier="float32", shift_rounding="half_even", float_rounding="half_even",
        depthwise_vector_channels=0, depthwise_tail="ort-cpu",
        quantize_reciprocal=False, quantize_rounding="half_even", table_rounding="half_even",
        add="float32_fma", mul="onnxruntime", average_pool="onnxruntime", resize_bilinear="onnxruntime",
        quantize="scalar", dequantize="exact", requantize="onnxruntime",
    ),
}
DEFAULT_RUNTIME = "tflite-ref"


def get_runtime(runtime: str | Runtime) -> Runtime:
    """A :class:`Runtime` by name (or the runtime itself); ``ValueError`` naming the choices."""
    if isinstance(runtime, Runtime):
        return runtime
    try:
        return RUNTIMES[runtime]
    except KeyError:
        raise ValueError(f"unknown runtime {runtime!r} (one of: {', '.join(RUNTIMES)})") from None


def runtime_names(engine: str | None = None) -> tuple[str, ...]:
    """Names of every runtime, or of those one engine (``litert``, ``onnxruntime``) runs: CLI choices."""
    return tuple(name for name, r in RUNTIMES.items() if engine is None or r.engine == engine)

