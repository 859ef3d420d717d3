"""Integer quantization arithmetic, the one definition the quantizer, the exporters and the emulator share.

Affine quantization maps a real value ``r`` to an integer ``q`` with
``r = scale * (q - zero_point)``.  Activations are per-tensor asymmetric int8
(or symmetric int16, zero point 0); weights are symmetric int8 in [-127, 127]
with one scale per output channel; a bias is int32 with scale
``input_scale * weight_scale[c]`` and zero point 0.

A convolution accumulates ``sum((x_q - x_zp) * w_q) + bias_q`` exactly in
int32 and then *requantizes*: multiplies by ``s_in * s_w[c] / s_out``, rounds,
adds the output zero point and clamps.  Runtimes do that last step
differently, and the difference is visible (<= 1 LSB on a small fraction of
values, compounding with depth).  Each runtime is a ``mnss_kit.ops.runtimes.Runtime``,
plain data naming its rounding rules; every function here takes a runtime (or its name)
and branches on its fields only:

``q31`` (``tflite-ref``, ``tflite-builtin``)  The real multiplier becomes an int32 Q31
    mantissa and a power-of-two shift (:func:`quantize_multiplier`); the product is
    ``rounding_divide_by_pot(saturating_rounding_doubling_high_mul(x << left, m), right)``:
    two roundings, the high multiply's ties toward +infinity and the shift's ties away from
    zero (``tflite-ref``) or half up, ``(x + 2^(n-1)) >> n`` (``tflite-builtin``).
``float32`` (``xnnpack``, ``ort-cpu``)  float32 ``scale = s_in * s_w / s_out``,
    ``float32(acc) * scale`` rounded half to even, then zero point and clamp.

ADD has four methods (:func:`add`); QUANTIZE and the LOGISTIC/TANH tables read the
runtime's rounding fields (:func:`quantize`, :func:`lookup_table`).

All integer arithmetic is carried out in int64 numpy arrays so intermediate
products never overflow; results are returned in the dtype the runtime stores.
"""

from __future__ import annotations

import math

import numpy as np

from .runtimes import Runtime, get_runtime

INT8_MIN, INT8_MAX = -128, 127
INT16_MIN, INT16_MAX = -32768, 32767
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1
WEIGHT_MAX = 127  # symmetric int8 weights use [-127, 127]


def qrange(dtype: str | np.dtype) -> tuple[int, int]:
    """Inclusive integer range of an activation dtype (``int8`` or ``int16``)."""
    name = np.dtype(dtype).name
    if name == "int8":
        return INT8_MIN, INT8_MAX
    if name == "int16":
        return INT16_MIN, INT16_MAX
    if name == "int32":
        return INT32_MIN, INT32_MAX
    raise ValueError(f"no quantized range for dtype {name}")


# ---------------------------------------------------------------------------
# Rounding primitives (vectorized; exact in int64 / float64)


def round_float(x: np.ndarray, rounding: str) -> np.ndarray:
    """Round float values to integers (float64 result) with the named tie rule."""
    x = np.asarray(x, dtype=np.float64)
    if rounding == "half_even":
        return np.rint(x)
    if rounding == "away_from_zero":  # C/C++ std::round
        return np.sign(x) * np.floor(np.abs(x) + 0.5)
    if rounding == "half_up":
        return np.floor(x + 0.5)
    raise ValueError(f"unknown rounding {rounding!r}")


def _trunc_div(a: np.ndarray, d: int) -> np.ndarray:
    """C integer division (rounds toward zero) of int64 ``a`` by positive ``d``."""
    q = np.abs(a) // d
    return np.where(a < 0, -q, q)


def saturating_rounding_doubling_high_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """gemmlowp ``SaturatingRoundingDoublingHighMul``: ``round(a * b / 2^31)``, ties toward +infinity.

    (gemmlowp adds a nudge of ``2^30`` or ``1 - 2^30`` and divides with C
    truncation, so -1.5 becomes -1 and 1.5 becomes 2.)

    ``a``, ``b``: int32 values (any integer dtype, broadcastable).  Returns int64
    holding int32 values; the one overflow case ``a = b = -2^31`` saturates to
    ``2^31 - 1``.
    """
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    ab = a * b  # |ab| <= 2^62: fits int64
    nudge = np.where(ab >= 0, np.int64(1 << 30), np.int64(1 - (1 << 30)))
    high = _trunc_div(ab + nudge, 1 << 31)
    overflow = (a == INT32_MIN) & (b == INT32_MIN)
    return np.where(overflow, np.int64(INT32_MAX), high)


def rounding_divide_by_pot(x: np.ndarray, exponent: np.ndarray) -> np.ndarray:
    """gemmlowp ``RoundingDivideByPOT``: ``round(x / 2^exponent)``, ties away from zero.

    ``x`` int64 holding int32 values, ``exponent`` in [0, 31] (broadcastable).
    """
    x = np.asarray(x, dtype=np.int64)
    exponent = np.asarray(exponent, dtype=np.int64)
    mask = (np.int64(1) << exponent) - 1
    remainder = x & mask
    threshold = (mask >> 1) + (x < 0)
    return (x >> exponent) + (remainder > threshold)


def rounding_shift_half_up(x: np.ndarray, exponent: np.ndarray) -> np.ndarray:
    """``(x + 2^(exponent-1)) >> exponent`` (arithmetic shift): ties toward +infinity; exponent 0 is identity."""
    x = np.asarray(x, dtype=np.int64)
    exponent = np.asarray(exponent, dtype=np.int64)
    half = np.where(exponent > 0, np.int64(1) << np.maximum(exponent - 1, 0), 0)
    return (x + half) >> exponent


# ---------------------------------------------------------------------------
# Multipliers


def quantize_multiplier(real_multiplier: float) -> tuple[int, int]:
    """TFLite ``QuantizeMultiplier``: ``real ~= m * 2^(shift - 31)`` with ``m`` in [2^30, 2^31).

    ``real_multiplier`` is a float64 computed by the caller (TFLite builds it in
    double from the float32 scales).  Returns ``(m, shift)``; ``shift > 0`` is a
    left shift.  Values below 2^-32 flush to ``(0, 0)``.
    """
    if real_multiplier == 0.0:
        return 0, 0
    if real_multiplier < 0.0:
        raise ValueError("multipliers are non-negative")
    fraction, shift = math.frexp(real_multiplier)  # fraction in [0.5, 1)
    q = int(round_float(fraction * (1 << 31), "away_from_zero"))
    if q == 1 << 31:
        q //= 2
        shift += 1
    if shift < -31:
        return 0, 0
    if shift > 30:
        return INT32_MAX, 30
    return q, shift


def quantize_multiplier_smaller_than_one(real_multiplier: float) -> tuple[int, int]:
    """TFLite ``QuantizeMultiplierSmallerThanOneExp``: as :func:`quantize_multiplier` for ``real < 1``; shift <= 0."""
    if not 0.0 <= real_multiplier < 1.0:
        raise ValueError(f"multiplier {real_multiplier} is not in [0, 1)")
    return quantize_multiplier(real_multiplier)


def effective_multiplier(input_scale: float, weight_scales: np.ndarray, output_scale: float, runtime: Runtime) -> np.ndarray:
    """Per-channel real multiplier ``s_in * s_w[c] / s_out`` as the runtime computes it.

    ``q31`` runtimes compute in float64 from the float32 scales (TFLite
    ``PopulateConvolutionQuantizationParams``); ``float32`` runtimes compute
    ``(s_in * s_w) / s_out`` with float32 rounding after each operation.
    Returns float64 (q31) or float32 (float32) array of shape ``(C,)``.
    """
    s_w = np.atleast_1d(np.asarray(weight_scales, dtype=np.float32))
    if runtime.multiplier == "q31":
        return np.float64(np.float32(input_scale)) * s_w.astype(np.float64) / np.float64(np.float32(output_scale))
    product = (np.float32(input_scale) * s_w).astype(np.float32)
    return (product / np.float32(output_scale)).astype(np.float32)


def multiply_by_quantized_multiplier(x: np.ndarray, multiplier: np.ndarray, shift: np.ndarray, shift_rounding: str) -> np.ndarray:
    """TFLite ``MultiplyByQuantizedMultiplier`` on int32 values: ``x * m * 2^(shift-31)``.

    ``x`` int32 values (int64 array ok); ``multiplier`` (int32 Q31) and ``shift``
    broadcast against ``x`` (per channel on the last axis).  A positive shift is
    applied as a left shift before the high multiply, a negative one as a
    rounding right shift after it.  Returns int64 holding int32 values.
    """
    x = np.asarray(x, dtype=np.int64)
    shift = np.asarray(shift, dtype=np.int64)
    left = np.maximum(shift, 0)
    right = np.maximum(-shift, 0)
    # The left-shifted value is an int32 in the runtimes; wrap like two's complement.
    shifted = ((x << left) + (1 << 31)) % (1 << 32) - (1 << 31)
    high = saturating_rounding_doubling_high_mul(shifted, multiplier)
    if shift_rounding == "away_from_zero":
        return rounding_divide_by_pot(high, right)
    if shift_rounding == "half_up":
        return rounding_shift_half_up(high, right)
    raise ValueError(f"unknown shift rounding {shift_rounding!r}")


def multiply_by_quantized_multiplier_single_round(x: np.ndarray, multiplier: int, shift: int) -> np.ndarray:
    """``round(x * m / 2^(31 - shift))`` rounded once, ties toward +infinity.  ``shift <= 0``; int64 result."""
    x = np.asarray(x, dtype=np.int64)
    total = 31 - int(shift)
    # |x| < 2^31 and m < 2^31, so x * m fits int64.
    return (x * np.int64(multiplier) + (np.int64(1) << (total - 1))) >> total


# ---------------------------------------------------------------------------
# Tensors


def choose_qparams(rmin: float, rmax: float, dtype: str = "int8", symmetric: bool = False) -> tuple[np.float32, int]:
    """Scale and zero point covering ``[rmin, rmax]`` (widened to include 0).

    Asymmetric (int8 activations): ``scale = (rmax - rmin) / 255`` and the zero
    point ``round(qmin - rmin / scale)`` (ties away from zero) clamped to the
    range, so real 0 is exactly representable.  Symmetric (int16 activations):
    ``scale = max(|rmin|, |rmax|) / qmax``, zero point 0.  A degenerate range
    gets scale 1 (values are then exactly 0).  Returns ``(float32 scale, int zp)``.
    """
    qmin, qmax = qrange(dtype)
    rmin, rmax = min(float(rmin), 0.0), max(float(rmax), 0.0)
    if symmetric:
        bound = max(-rmin, rmax)
        scale = np.float32(bound / qmax) if bound > 0 else np.float32(1.0)
        return scale, 0
    if rmax == rmin:
        return np.float32(1.0), 0
    scale = np.float32((rmax - rmin) / (qmax - qmin))
    zero_point = int(round_float(qmin - rmin / float(scale), "away_from_zero"))
    return scale, int(np.clip(zero_point, qmin, qmax))


def quantize(x: np.ndarray, scale: float, zero_point: int, dtype: str = "int8", runtime: str | Runtime = "tflite-ref") -> np.ndarray:
    """The QUANTIZE op: float32 ``x`` -> ``clamp(round(x / scale) + zero_point)`` in ``dtype``.

    The runtime fixes how ``x / scale`` is computed (true float32 division or
    multiplication by the float32 reciprocal) and how ties round.
    """
    p = get_runtime(runtime)
    x = np.asarray(x, dtype=np.float32)
    scale = np.float32(scale)
    if p.quantize_reciprocal:
        scaled = x * (np.float32(1.0) / scale)
    else:
        scaled = x / scale
    q = round_float(scaled.astype(np.float32), p.quantize_rounding) + zero_point
    qmin, qmax = qrange(dtype)
    return np.clip(q, qmin, qmax).astype(dtype)


def dequantize(q: np.ndarray, scale: float | np.ndarray, zero_point: int | np.ndarray = 0, axis: int | None = None) -> np.ndarray:
    """The DEQUANTIZE op: ``float32(scale * (q - zero_point))`` (correctly rounded float32 product).

    Per-channel parameters are given as arrays with ``axis`` naming the channel axis of ``q``.
    """
    q = np.asarray(q, dtype=np.int64)
    scale = np.asarray(scale, dtype=np.float32)
    zero_point = np.asarray(zero_point, dtype=np.int64)
    if axis is not None and scale.ndim == 1:
        shape = [1] * q.ndim
        shape[axis] = -1
        scale = scale.reshape(shape)
        zero_point = zero_point.reshape(shape) if zero_point.ndim == 1 else zero_point
    return ((q - zero_point).astype(np.float32) * scale).astype(np.float32)


def quantize_weights_per_channel(w: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric int8 weights with one scale per channel along ``axis``.

    ``scale[c] = max|w[c]| / 127`` (float32; an all-zero channel gets scale 1),
    ``q = clamp(round(w / scale), -127, 127)`` with ties away from zero.
    Returns ``(q int8 same shape as w, scales float32 (C,))``.
    """
    w = np.asarray(w, dtype=np.float32)
    other = tuple(i for i in range(w.ndim) if i != axis % w.ndim)
    bound = np.max(np.abs(w), axis=other) if other else np.abs(w)
    scales = np.where(bound > 0, bound / np.float32(WEIGHT_MAX), np.float32(1.0)).astype(np.float32)
    return quantize_weights_with_scales(w, scales, axis), scales


def quantize_weights_with_scales(w: np.ndarray, scales: np.ndarray, axis: int) -> np.ndarray:
    """``clamp(round(w / scale[c]), -127, 127)`` as int8 for given per-channel float32 ``scales``."""
    w = np.asarray(w, dtype=np.float32)
    shape = [1] * w.ndim
    shape[axis] = -1
    scaled = w / np.asarray(scales, dtype=np.float32).reshape(shape)
    return np.clip(round_float(scaled, "away_from_zero"), -WEIGHT_MAX, WEIGHT_MAX).astype(np.int8)


def bias_scales(input_scale: float, weight_scales: np.ndarray) -> np.ndarray:
    """Bias scale per channel, ``float32(s_in * s_w[c])`` (float32, shape (C,))."""
    return (np.float32(input_scale) * np.asarray(weight_scales, dtype=np.float32)).astype(np.float32)


def quantize_bias(bias: np.ndarray, input_scale: float, weight_scales: np.ndarray) -> np.ndarray:
    """int32 bias ``round(b / (s_in * s_w[c]))`` (ties away from zero), zero point 0.

    Raises ``ValueError`` if a value does not fit int32 (the caller should
    raise that channel's weight scale).  Returns int32 (C,).
    """
    scale = bias_scales(input_scale, weight_scales).astype(np.float64)
    q = round_float(np.asarray(bias, dtype=np.float64) / scale, "away_from_zero")
    if np.any(q > INT32_MAX) or np.any(q < INT32_MIN):
        raise ValueError("bias does not fit int32 at this input and weight scale")
    return q.astype(np.int32)


# ---------------------------------------------------------------------------
# Integer accumulation (exact; slow reference)


def conv2d_accumulate(
    x: np.ndarray,
    x_zero_point: int,
    w: np.ndarray,
    bias: np.ndarray,
    stride: tuple[int, int] = (1, 1),
    padding: tuple[int, int, int, int] = (0, 0, 0, 0),
    dilation: tuple[int, int] = (1, 1),
    depthwise: bool = False,
) -> np.ndarray:
    """int32 accumulator of CONV_2D / DEPTHWISE_CONV_2D: ``sum((x - x_zp) * w) + bias``.

    ``x``: (N, H, W, Cin) integer.  ``w``: (Cout, KH, KW, Cin) int8 (OHWI) for a
    convolution, (1, KH, KW, C) for a depthwise one (multiplier 1).  ``bias``:
    (Cout,) int32.  ``padding`` = (top, bottom, left, right); padded positions
    hold the input zero point, i.e. contribute 0.  Returns int64 (N, OH, OW, Cout)
    holding the int32 accumulator (the runtimes assume no int32 overflow).
    """
    xs = np.asarray(x, dtype=np.int64) - x_zero_point
    top, bottom, left, right = padding
    xs = np.pad(xs, ((0, 0), (top, bottom), (left, right), (0, 0)))
    w = np.asarray(w, dtype=np.int64)
    _, kh, kw, _ = w.shape
    (sy, sx), (dy, dx) = stride, dilation
    oh = (xs.shape[1] - dy * (kh - 1) - 1) // sy + 1
    ow = (xs.shape[2] - dx * (kw - 1) - 1) // sx + 1
    cout = w.shape[3] if depthwise else w.shape[0]
    acc = np.zeros((xs.shape[0], oh, ow, cout), dtype=np.int64)
    for ky in range(kh):
        for kx in range(kw):
            y0, x0 = ky * dy, kx * dx
            patch = xs[:, y0 : y0 + sy * (oh - 1) + 1 : sy, x0 : x0 + sx * (ow - 1) + 1 : sx, :]
            if depthwise:
                acc += patch * w[0, ky, kx, :]
            else:
                acc += np.einsum("nhwc,oc->nhwo", patch, w[:, ky, kx, :])
    return acc + np.asarray(bias, dtype=np.int64)


# ---------------------------------------------------------------------------
# Requantization


def requantize(
    acc: np.ndarray,
    input_scale: float,
    weight_scales: np.ndarray,
    output_scale: float,
    output_zero_point: int,
    runtime: str | Runtime,
    dtype: str = "int8",
    clamp: tuple[int, int] | None = None,
) -> np.ndarray:
    """int32 accumulator ``(..., C)`` (channels last) -> ``dtype`` output of CONV_2D / DEPTHWISE_CONV_2D.

    ``acc = sum((x_q - x_zp) * w_q) + bias_q`` (int32, exact).  ``weight_scales``
    is (C,) or scalar.  ``clamp`` are the fused-activation bounds in the output
    integer domain (default: the dtype's range).
    """
    p = get_runtime(runtime)
    acc = np.asarray(acc, dtype=np.int64)
    real = effective_multiplier(input_scale, weight_scales, output_scale, p)
    if p.multiplier == "q31":
        pairs = [quantize_multiplier(float(r)) for r in real]
        mult = np.array([m for m, _ in pairs], dtype=np.int64)
        shift = np.array([s for _, s in pairs], dtype=np.int64)
        scaled = multiply_by_quantized_multiplier(acc, mult, shift, p.shift_rounding)
    else:
        product = acc.astype(np.float32) * real  # float32(acc): exact only below 2^24, as in the runtime
        scaled = round_float(product.astype(np.float32), p.float_rounding)
    lo, hi = clamp if clamp is not None else qrange(dtype)
    return np.clip(scaled + output_zero_point, lo, hi).astype(dtype)


def activation_bounds(activation: str, scale: float, zero_point: int, dtype: str = "int8") -> tuple[int, int]:
    """Integer clamp bounds of a fused activation (``none``, ``relu``, ``relu6``, ``relu_n1_to_1``).

    As TFLite ``CalculateActivationRangeQuantized``: real bounds quantized with
    ties away from zero, intersected with the dtype's range.
    """
    qmin, qmax = qrange(dtype)
    real = {"none": (None, None), "relu": (0.0, None), "relu6": (0.0, 6.0), "relu_n1_to_1": (-1.0, 1.0)}[activation]

    def q(v):
        return int(zero_point + round_float(np.float32(v) / np.float32(scale), "away_from_zero"))

    lo = qmin if real[0] is None else max(qmin, q(real[0]))
    hi = qmax if real[1] is None else min(qmax, q(real[1]))
    return lo, hi


# ---------------------------------------------------------------------------
# Elementwise ops

ADD_LEFT_SHIFT = {"int8": 20, "int16": 15}


def add(
    a: np.ndarray,
    a_params: tuple[float, int],
    b: np.ndarray,
    b_params: tuple[float, int],
    out_params: tuple[float, int],
    method: str,
    dtype: str = "int8",
    clamp: tuple[int, int] | None = None,
) -> np.ndarray:
    """Quantized ADD of two broadcastable integer tensors; params are ``(scale, zero_point)``.

    ``method`` (one of ``runtimes.ADD_METHODS``):

    ``q31_double_round`` (LiteRT reference)
        Each input, offset by its zero point and shifted left by 20 bits
        (int8), is rescaled to ``2 * max(s_a, s_b)`` with a Q31 multiplier;
        the sum is rescaled to the output scale.  All three rescales use
        double rounding (ties away from zero).
    ``q31_single_round_inputs`` (the vector body of LiteRT's optimized kernel, x86-64)
        As above, but the two input rescales round once, half up:
        ``(x * m + 2^(30 - shift)) >> (31 - shift)``.
    ``xnnpack_fixed_point``
        ``r = s_x / s_o`` in float32; ``shift = 20 - exponent(max(r_a, r_b))``;
        ``m_x = rint(r_x * 2^shift)``; the int32 sum
        ``2^(shift-1) - m_a z_a - m_b z_b + m_a a + m_b b`` is shifted right
        arithmetically by ``shift`` (ties toward +infinity).
    ``float32_fma`` (ONNX Runtime MLAS)
        ``r_x = s_x / s_o`` and ``bias = z_o - fma(r_a, z_a, r_b z_b)`` in float32;
        ``rint(fma(a, r_a, fma(b, r_b, bias)))`` (round half to even), with
        ``a``, ``b`` the raw integers.
    """
    (sa, za), (sb, zb), (so, zo) = a_params, b_params, out_params
    sa, sb, so = np.float32(sa), np.float32(sb), np.float32(so)
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    if method in ("q31_double_round", "q31_single_round_inputs"):
        left = ADD_LEFT_SHIFT[np.dtype(dtype).name]
        twice_max = 2.0 * max(float(sa), float(sb))
        ma, sha = quantize_multiplier_smaller_than_one(float(sa) / twice_max)
        mb, shb = quantize_multiplier_smaller_than_one(float(sb) / twice_max)
        mo, sho = quantize_multiplier_smaller_than_one(twice_max / ((1 << left) * float(so)))
        if method == "q31_double_round":
            scaled_a = multiply_by_quantized_multiplier((a - za) << left, ma, sha, "away_from_zero")
            scaled_b = multiply_by_quantized_multiplier((b - zb) << left, mb, shb, "away_from_zero")
        else:
            scaled_a = multiply_by_quantized_multiplier_single_round((a - za) << left, ma, sha)
            scaled_b = multiply_by_quantized_multiplier_single_round((b - zb) << left, mb, shb)
        out = multiply_by_quantized_multiplier(scaled_a + scaled_b, mo, sho, "away_from_zero") + zo
    elif method == "xnnpack_fixed_point":
        ra, rb = np.float32(sa / so), np.float32(sb / so)
        exponent = int(np.array(max(ra, rb), dtype=np.float32).view(np.uint32) >> 23) - 127
        shift = 20 - exponent
        ma = int(np.rint(np.float64(ra) * 2.0**shift))  # exact power-of-two scaling, then round half even
        mb = int(np.rint(np.float64(rb) * 2.0**shift))
        bias = (1 << (shift - 1)) - ma * za - mb * zb
        out = ((bias + a * ma + b * mb) >> shift) + zo
    elif method == "float32_fma":
        ra, rb = np.float32(sa / so), np.float32(sb / so)
        bias = np.float32(np.float32(zo) - fma_f32(ra, np.float32(za), np.float32(rb * np.float32(zb))))
        inner = fma_f32(b.astype(np.float32), rb, bias)
        out = np.rint(fma_f32(a.astype(np.float32), ra, inner))  # round half to even
    else:
        raise ValueError(f"unknown add method {method!r}")
    lo, hi = clamp if clamp is not None else qrange(dtype)
    return np.clip(out, lo, hi).astype(dtype)


def fma_f32(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Fused multiply-add of float32 values, rounded once to float32.

    Emulated in float64: the product of two float32 is exact there, and the
    sum is rounded first to float64 and then to float32, which can only
    differ from a true single rounding when the float64 result sits exactly
    on a float32 tie (not reachable with int8 operands and scales in use).
    """
    a, b, c = (np.asarray(v, dtype=np.float64) for v in (a, b, c))
    return (a * b + c).astype(np.float32)


def lookup_table(fn, in_params: tuple[float, int], out_params: tuple[float, int], runtime: str | Runtime) -> np.ndarray:
    """256-entry int8 table of ``fn`` (a float32 numpy ufunc-like) indexed by ``q + 128``.

    Built in float32 as the runtimes do: ``x = s_in * (q - z_in)``,
    ``y = round(fn(x) * (1 / s_out)) + z_out`` (the runtime's ``table_rounding``), clamped to
    int8.  Returns int8 (256,).
    """
    p = get_runtime(runtime)
    (s_in, z_in), (s_out, z_out) = in_params, out_params
    q = np.arange(INT8_MIN, INT8_MAX + 1, dtype=np.int64)
    x = (np.float32(s_in) * (q - z_in).astype(np.float32)).astype(np.float32)
    y = np.asarray(fn(x), dtype=np.float32)
    scaled = (y * (np.float32(1.0) / np.float32(s_out))).astype(np.float32)
    return np.clip(round_float(scaled, p.table_rounding) + z_out, INT8_MIN, INT8_MAX).astype(np.int8)


def sigmoid_f32(x: np.ndarray) -> np.ndarray:
    """``1 / (1 + exp(-x))`` in float32 (exp overflow gives 1/inf = 0, the right limit)."""
    x = np.asarray(x, dtype=np.float32)
    with np.errstate(over="ignore"):
        return (np.float32(1.0) / (np.float32(1.0) + np.exp(-x))).astype(np.float32)


def tanh_f32(x: np.ndarray) -> np.ndarray:
    return np.tanh(np.asarray(x, dtype=np.float32)).astype(np.float32)


LOGISTIC_OUTPUT = (np.float32(1.0 / 256.0), -128)  # fixed output params of int8 LOGISTIC
TANH_OUTPUT = (np.float32(1.0 / 128.0), 0)  # fixed output params of int8 TANH


def apply_table(q: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Look up int8 ``q`` in a 256-entry int8 table built by :func:`lookup_table`."""
    return table[np.asarray(q, dtype=np.int64) - INT8_MIN]


def average_pool_round(total: np.ndarray, count: int) -> np.ndarray:
    """Integer average of a window sum, ties away from zero (TFLite reference AVERAGE_POOL_2D)."""
    total = np.asarray(total, dtype=np.int64)
    half = count // 2
    return np.where(total > 0, _trunc_div(total + half, count), _trunc_div(total - half, count))
