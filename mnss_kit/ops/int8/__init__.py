"""The int8 ops, one slow exact numpy definition each (as LiteRT's reference kernels), one file per op.

The quantizer, the exporters and the emulator share these; a runtime
(``mnss_kit.ops.runtimes.RUNTIMES``) is plain data naming which formula of each op it uses.

==============================================  =====================
op or step                                      file
==============================================  =====================
dtype ranges, ``QParams``                       ``ranges.py``
rounding (tie rules, gemmlowp high-mul and      ``rounding.py``
RoundingDivideByPOT, half-up shift)
Q31 multipliers, MultiplyByQuantizedMultiplier  ``multiplier.py``
tensor params, QUANTIZE / DEQUANTIZE formulas   ``quantize.py``
conv weights (per channel) and int32 bias       ``weights.py``
CONV_2D / DEPTHWISE_CONV_2D accumulator         ``conv.py``
requantization (conv output stage, fused        ``requantize.py``
activation bounds, QUANTIZE int8 -> int8)
ADD (four methods)                              ``add.py``
MUL                                             ``mul.py``
LOGISTIC, TANH (256-entry tables)               ``logistic_tanh.py``
AVERAGE_POOL_2D                                 ``average_pool.py``
RESIZE_BILINEAR                                 ``resize_bilinear.py``
the runtime's ADD / QUANTIZE / DEQUANTIZE,      ``vector.py``
LiteRT's vector blocks and scalar tail
==============================================  =====================

Each module names the runtimes' formulas it holds; numpy only.
"""
