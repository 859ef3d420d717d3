"""Reference integer arithmetic: rounding edge cases, saturation, and agreement with real arithmetic.

Agreement with the runtimes themselves (LiteRT, ONNX Runtime) is in
tests/quantize/test_profiles.py.
"""

import numpy as np
import pytest
import torch

from mnss_kit.ops.int8.add import add
from mnss_kit.ops.int8.average_pool import average_pool_round
from mnss_kit.ops.int8.conv import conv2d_accumulate
from mnss_kit.ops.int8.logistic_tanh import LOGISTIC_OUTPUT, apply_table, lookup_table, sigmoid_f32
from mnss_kit.ops.int8.multiplier import quantize_multiplier
from mnss_kit.ops.int8.quantize import choose_qparams, dequantize, quantize
from mnss_kit.ops.int8.ranges import INT32_MAX, INT32_MIN
from mnss_kit.ops.int8.requantize import activation_bounds, requantize
from mnss_kit.ops.int8.rounding import rounding_divide_by_pot, rounding_shift_half_up, saturating_rounding_doubling_high_mul
from mnss_kit.ops.int8.weights import quantize_bias, quantize_weights_per_channel
from mnss_kit.ops.runtimes import ADD_METHODS, RUNTIMES

PROFILES = list(RUNTIMES)


def test_rounding_divide_by_pot_ties_away_from_zero():
    x = np.array([5, -5, 6, -6, 7, -7, 0, 1, -1])
    assert rounding_divide_by_pot(x, 1).tolist() == [3, -3, 3, -3, 4, -4, 0, 1, -1]
    assert rounding_divide_by_pot(x, 0).tolist() == x.tolist()


def test_rounding_shift_half_up():
    x = np.array([5, -5, 7, -7, 6])
    assert rounding_shift_half_up(x, 1).tolist() == [3, -2, 4, -3, 3]


def test_high_mul_rounding_and_saturation():
    half = 1 << 30  # 0.5 in Q31
    a = np.array([3, -3, 1, -1, INT32_MIN])
    b = np.array([half, half, half, half, INT32_MIN])
    # 1.5 -> 2, -1.5 -> -1 (ties toward +inf), 0.5 -> 1, -0.5 -> 0, (-1)*(-1) saturates
    assert saturating_rounding_doubling_high_mul(a, b).tolist() == [2, -1, 1, 0, INT32_MAX]


@pytest.mark.parametrize("real", [1e-6, 0.0012345, 0.25, 0.5, 0.999999999, 1.0, 3.7, 100.0])
def test_quantize_multiplier_reconstructs(real):
    m, shift = quantize_multiplier(real)
    assert (1 << 30) <= m < (1 << 31)
    assert abs(m * 2.0 ** (shift - 31) - real) <= real * 2.0**-30


def test_quantize_multiplier_edge_cases():
    assert quantize_multiplier(0.0) == (0, 0)
    assert quantize_multiplier(2.0**-40) == (0, 0)
    # a mantissa that rounds up to 2^31 moves to the next exponent
    m, shift = quantize_multiplier(1.0 - 2.0**-40)
    assert (m, shift) == (1 << 30, 1)


@pytest.mark.parametrize("profile", PROFILES)
def test_requantize_close_to_real_arithmetic(profile):
    rng = np.random.default_rng(0)
    acc = rng.integers(-200_000, 200_000, size=(1000, 4))
    s_in, s_out, s_w = 0.02, 0.07, np.array([0.001, 0.003, 0.0005, 0.01], np.float32)
    got = requantize(acc, s_in, s_w, s_out, 3, profile)
    exact = np.clip(np.round(acc * (np.float64(np.float32(s_in)) * s_w / np.float64(np.float32(s_out)))) + 3, -128, 127)
    assert np.abs(got.astype(int) - exact).max() <= 1
    assert got.dtype == np.int8


def test_profiles_differ_only_at_ties():
    """The four requantizations agree except near rounding ties (<= 1 LSB, rare)."""
    rng = np.random.default_rng(1)
    acc = rng.integers(-100_000, 100_000, size=(20000, 1))
    outs = [requantize(acc, 0.013, np.float32(0.0021), 0.041, -5, p).astype(int) for p in PROFILES]
    for o in outs[1:]:
        diff = np.abs(o - outs[0])
        assert diff.max() <= 1
        assert diff.mean() < 0.01


def test_requantize_double_rounding_differs_from_half_up_at_a_tie():
    # multiplier 0.75 * 2^-2: x * m lands on .5 after the high multiply for x = 2
    acc = np.array([[2], [-2], [6], [-6]])
    ref = requantize(acc, 1.0, np.float32(0.25), 1.0, 0, "tflite-ref")
    opt = requantize(acc, 1.0, np.float32(0.25), 1.0, 0, "tflite-builtin")
    assert ref[:, 0].tolist() == [1, -1, 2, -2]  # ties away from zero
    assert opt[:, 0].tolist() == [1, 0, 2, -1]  # ties toward +inf


def test_requantize_clamp_bounds():
    acc = np.array([[-1000], [1000]])
    out = requantize(acc, 1.0, np.float32(1.0), 1.0, -128, "tflite-ref", clamp=(-128, 0))
    assert out[:, 0].tolist() == [-128, 0]


@pytest.mark.parametrize("profile", PROFILES)
def test_quantize_dequantize_roundtrip(profile):
    x = np.linspace(-1.0, 2.0, 1001, dtype=np.float32)
    scale, zp = choose_qparams(-1.0, 2.0)
    q = quantize(x, scale, zp, runtime=profile)
    assert np.abs(dequantize(q, scale, zp) - x).max() <= scale / 2 * 1.001


def test_quantize_ties():
    x = np.array([0.5, 1.5, 2.5, -0.5, -2.5], np.float32)
    assert quantize(x, 1.0, 0, runtime="tflite-ref").tolist() == [1, 2, 3, -1, -3]
    assert quantize(x, 1.0, 0, runtime="ort-cpu").tolist() == [0, 2, 2, -0, -2]


def test_choose_qparams_zero_exact_and_symmetric():
    for lo, hi in [(-0.3, 1.7), (0.2, 5.0), (-4.0, -1.0), (0.0, 1.0)]:
        scale, zp = choose_qparams(lo, hi)
        assert -128 <= zp <= 127
        assert dequantize(np.array([zp]), scale, zp)[0] == 0.0
    assert choose_qparams(0.0, 1.0) == (np.float32(1 / 255), -128)
    scale, zp = choose_qparams(-2.0, 1.0, "int16", symmetric=True)
    assert zp == 0 and np.isclose(scale, 2.0 / 32767)


def test_weights_per_channel_symmetric():
    rng = np.random.default_rng(0)
    w = rng.normal(size=(8, 3, 3, 4)).astype(np.float32)
    w[3] = 0.0
    q, s = quantize_weights_per_channel(w, axis=0)
    assert q.dtype == np.int8 and s.shape == (8,)
    assert q.min() >= -127 and q.max() <= 127
    assert np.all(np.abs(q.reshape(8, -1)).max(axis=1)[[0, 1, 2, 4, 5, 6, 7]] == 127)
    assert np.all(q[3] == 0)
    err = np.abs(dequantize(q, s, 0, axis=0) - w)
    assert np.all(err <= s[:, None, None, None] / 2 * 1.001)


def test_bias_int32_and_overflow():
    b = np.array([0.5, -0.25], np.float32)
    q = quantize_bias(b, 0.01, np.array([0.1, 0.05], np.float32))
    assert q.dtype == np.int32 and q.tolist() == [500, -500]
    with pytest.raises(ValueError):
        quantize_bias(np.array([1e6], np.float32), 1e-4, np.array([1e-4], np.float32))


@pytest.mark.parametrize("depthwise", [False, True])
def test_conv_accumulate_matches_float_conv(depthwise):
    rng = np.random.default_rng(0)
    x = rng.integers(-128, 128, size=(1, 9, 10, 4))
    cout = 4 if depthwise else 6
    w = rng.integers(-127, 128, size=(1, 3, 3, 4) if depthwise else (cout, 3, 3, 4))
    bias = rng.integers(-1000, 1000, size=cout)
    acc = conv2d_accumulate(x, 7, w, bias, stride=(2, 2), padding=(1, 1, 0, 2), depthwise=depthwise)
    xt = torch.tensor(x - 7, dtype=torch.float64).permute(0, 3, 1, 2)
    xt = torch.nn.functional.pad(xt, (0, 2, 1, 1))
    wt = torch.tensor(w, dtype=torch.float64).permute(3, 0, 1, 2) if depthwise else torch.tensor(w, dtype=torch.float64).permute(0, 3, 1, 2)
    ref = torch.nn.functional.conv2d(xt, wt, torch.tensor(bias, dtype=torch.float64), stride=2, groups=4 if depthwise else 1)
    np.testing.assert_array_equal(acc, ref.permute(0, 2, 3, 1).numpy().astype(np.int64))


@pytest.mark.parametrize("method", ADD_METHODS)
def test_add_close_to_real_arithmetic(method):
    a = np.repeat(np.arange(-128, 128), 256)
    b = np.tile(np.arange(-128, 128), 256)
    pa, pb, po = (0.02, 5), (0.031, -7), (0.05, -3)
    got = add(a, pa, b, pb, po, method).astype(int)
    exact = np.clip(np.round((0.02 * (a - 5) + 0.031 * (b + 7)) / 0.05) - 3, -128, 127)
    assert np.abs(got - exact).max() <= 1


def test_logistic_table_monotone_and_fixed_output_params():
    for profile in PROFILES:
        t = lookup_table(sigmoid_f32, (0.05, 3), LOGISTIC_OUTPUT, profile)
        assert t.shape == (256,) and t.dtype == np.int8
        assert np.all(np.diff(t.astype(int)) >= 0)
        assert t[0] == -128 and t[-1] == 127
        x = np.array([3])  # real 0 -> sigmoid 0.5 -> q = 0
        assert apply_table(x, t)[0] == 0


def test_average_pool_round_ties_away():
    assert average_pool_round(np.array([2, -2, 3, -3, 1]), 4).tolist() == [1, -1, 1, -1, 0]


def test_activation_bounds():
    assert activation_bounds("relu", 0.1, -10) == (-10, 127)
    assert activation_bounds("relu6", 0.1, -10) == (-10, 50)
    assert activation_bounds("none", 0.1, -10) == (-128, 127)
