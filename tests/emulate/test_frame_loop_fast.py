"""The emulator's fast requantization equals the definitions in ops.int8 / emulate.kernels bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mnss_kit.emulate import fast, kernels
from mnss_kit.ops.int8.requantize import activation_bounds, requantize
from mnss_kit.ops.runtimes import RUNTIMES

SEEDS = st.integers(0, 2**32 - 1)
ACTIVATIONS = ("none", "relu", "relu6", "relu_n1_to_1")


def random_requantizer_case(seed: int):
    rng = np.random.default_rng(seed)
    channels = int(rng.integers(1, 20))
    acc = rng.integers(-(2**31), 2**31, size=(64, channels), dtype=np.int64)
    acc[:16] = rng.integers(-5000, 5000, size=(16, channels))
    acc[16] = np.int64(-(2**31))
    acc[17] = np.int64(2**31 - 1)
    # multipliers from far below to above 1 (positive and negative shifts), tie-prone powers of two half the time
    x_scale = np.float32(np.exp(rng.uniform(-9, 2)))
    out_scale = np.float32(x_scale * 2.0 ** int(rng.integers(-12, 4))) if seed % 2 else np.float32(np.exp(rng.uniform(-9, 2)))
    w_scales = np.exp(rng.uniform(-12, 4, size=channels)).astype(np.float32)
    if seed % 3 == 0:
        w_scales[:] = np.float32(2.0 ** int(rng.integers(-10, 3)))
    out_q = (out_scale, int(rng.integers(-128, 128)))
    return acc, (x_scale, int(rng.integers(-128, 128))), w_scales, out_q, ACTIVATIONS[seed % 4]


@pytest.mark.parametrize("runtime", list(RUNTIMES))
@given(seed=SEEDS)
def test_requantizer_equals_definition(runtime, seed):
    acc, x_q, w_scales, out_q, activation = random_requantizer_case(seed)
    clamp = activation_bounds(activation, out_q[0], out_q[1])
    expected = requantize(acc, x_q[0], w_scales, out_q[0], out_q[1], runtime, clamp=clamp)
    got = fast.Requantizer(x_q, w_scales, out_q, activation, runtime)(acc.copy())
    assert got.dtype == np.int8
    np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("runtime", ["tflite-ref", "tflite-builtin"])
def test_int32_safe_path_equals_definition_on_small_accumulators(runtime):
    rng = np.random.default_rng(3)
    acc = rng.integers(-(2**22), 2**22, size=(4096, 8), dtype=np.int64)
    acc[::97] = 2**21 + np.arange(8) * 2**15  # values with many trailing zero bits: rounding ties
    w_scales = (2.0 ** -np.arange(8)).astype(np.float32)
    expected = requantize(acc, 0.5, w_scales, 0.25, 3, runtime)
    got = fast.Requantizer((0.5, 0), w_scales, (0.25, 3), "none", runtime)(acc.copy(), fits_int32=True)
    np.testing.assert_array_equal(got, expected)


def random_conv_case(seed: int, depthwise: bool):
    rng = np.random.default_rng(seed)
    n, h, w = 1, int(rng.integers(1, 10)), int(rng.integers(1, 10))
    cin = int(rng.integers(1, 21))
    k, stride = int(rng.choice([1, 3, 5])), int(rng.choice([1, 2]))
    x = rng.integers(-128, 128, size=(n, h, w, cin)).astype(np.int8)
    if depthwise:
        cout = cin * int(rng.integers(1, 3))
        weights = rng.integers(-127, 128, size=(1, k, k, cout)).astype(np.int8)
    else:
        cout = int(rng.integers(1, 21))
        weights = rng.integers(-127, 128, size=(cout, k, k, cin)).astype(np.int8)
    bias = rng.integers(-(2**16), 2**16, size=cout).astype(np.int32)
    x_q = (np.float32(np.exp(rng.uniform(-6, 0))), int(rng.integers(-128, 128)))
    w_scales = np.exp(rng.uniform(-8, -2, size=cout)).astype(np.float32)
    out_q = (np.float32(np.exp(rng.uniform(-4, 1))), int(rng.integers(-128, 128)))
    return x, x_q, weights, w_scales, bias, out_q, stride, str(rng.choice(["SAME", "VALID"])), ACTIVATIONS[seed % 4]


@pytest.mark.parametrize("runtime", list(RUNTIMES))
@given(seed=SEEDS)
def test_fast_conv2d_equals_kernel(runtime, seed):
    x, x_q, weights, w_scales, bias, out_q, stride, padding, activation = random_conv_case(seed, depthwise=False)
    if padding == "VALID" and (x.shape[1] < weights.shape[1] or x.shape[2] < weights.shape[2]):
        padding = "SAME"
    expected = kernels.conv2d(x, x_q, weights, w_scales, bias, out_q, stride, padding, activation, runtime)
    requantizer = fast.Requantizer(x_q, w_scales, out_q, activation, runtime)
    np.testing.assert_array_equal(fast.conv2d(x, x_q, weights, bias, requantizer, stride, padding), expected)


@pytest.mark.parametrize("runtime", ["tflite-ref", "xnnpack"])
@given(seed=SEEDS)
def test_fast_conv2d_in_blocks_of_rows_equals_kernel(runtime, seed):
    """Blocks of one to a few output rows (with a shorter last block), strides 1 and 2, SAME and VALID."""
    x, x_q, weights, w_scales, bias, out_q, stride, padding, activation = random_conv_case(seed, depthwise=False)
    if padding == "VALID" and (x.shape[1] < weights.shape[1] or x.shape[2] < weights.shape[2]):
        padding = "SAME"
    expected = kernels.conv2d(x, x_q, weights, w_scales, bias, out_q, stride, padding, activation, runtime)
    requantizer = fast.Requantizer(x_q, w_scales, out_q, activation, runtime)
    block = int(np.prod(expected.shape[2:])) * (1 + seed % 3)  # output rows per block: 1, 2 or 3
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fast, "_BLOCK_VALUES", block)
        np.testing.assert_array_equal(fast.conv2d(x, x_q, weights, bias, requantizer, stride, padding), expected)


@pytest.mark.parametrize("runtime", list(RUNTIMES))
@given(seed=SEEDS)
def test_fast_depthwise_equals_kernel(runtime, seed):
    x, x_q, weights, w_scales, bias, out_q, stride, padding, activation = random_conv_case(seed, depthwise=True)
    if padding == "VALID" and (x.shape[1] < weights.shape[1] or x.shape[2] < weights.shape[2]):
        padding = "SAME"
    expected = kernels.depthwise_conv2d(x, x_q, weights, w_scales, bias, out_q, stride, padding, activation, runtime)
    requantizers = fast.DepthwiseRequantizers(x_q, w_scales, out_q, activation, weights.shape[3], runtime)
    np.testing.assert_array_equal(fast.depthwise_conv2d(x, x_q, weights, bias, requantizers, stride, padding), expected)


def test_fits_int32_bound():
    assert fast.fits_int32(288, np.array([1000], np.int32))
    assert not fast.fits_int32(70000, None)
    assert not fast.fits_int32(9, np.array([2**31 - 1], np.int32))


@pytest.mark.parametrize("kind", ["ADD", "MUL"])
@pytest.mark.parametrize("runtime", list(RUNTIMES))
@given(seed=SEEDS)
def test_pair_table_equals_kernel_where_exact(kind, runtime, seed):
    rng = np.random.default_rng(seed)
    ks = RUNTIMES[runtime]
    shape = (1, int(rng.integers(1, 12)), int(rng.integers(1, 12)), int(rng.integers(1, 9)))
    if not fast.pair_table_is_exact(kind, ks, int(np.prod(shape))):
        shape = (1, 4, 4, shape[3])  # a multiple of every vector width
    a = rng.integers(-128, 128, size=shape).astype(np.int8)
    b = rng.integers(-128, 128, size=shape).astype(np.int8)
    qs = [(np.float32(np.exp(rng.uniform(-6, 0))), int(rng.integers(-128, 128))) for _ in range(3)]
    activation = ACTIVATIONS[seed % 4]
    kernel = kernels.add if kind == "ADD" else kernels.mul
    expected = kernel(a, qs[0], b, qs[1], qs[2], activation, ks)
    got = fast.PairTable(kernel, qs[0], qs[1], qs[2], activation, ks)(a, b)
    np.testing.assert_array_equal(got, expected)


def test_pair_table_is_not_used_where_position_matters():
    optimized = RUNTIMES["tflite-builtin"]
    assert fast.pair_table_is_exact("ADD", optimized, 32) and not fast.pair_table_is_exact("ADD", optimized, 33)
    assert fast.pair_table_is_exact("MUL", optimized, 33)
    assert fast.pair_table_is_exact("ADD", RUNTIMES["tflite-ref"], 33)


@pytest.mark.parametrize("epilogue", ["none", "relu", "residual_clamp"])
def test_fast_gpu_conv3x3_equals_reference(epilogue):
    from mnss_kit.emulate.fast_gpu import FastReferencePasses, conv3x3_planar
    from mnss_kit.gpu.passes import call
    from mnss_kit.gpu.passes.conv3x3_pass import layer_uniforms
    from mnss_kit.gpu.reference import ReferencePasses
    from mnss_kit.gpu.weights import Conv3x3
    from mnss_kit.ops.inpaint import conv3x3

    rng = np.random.default_rng(4)
    for cin, cout in ((6, 8), (8, 3), (5, 1)):
        x = rng.normal(size=(13, 17, cin)).astype(np.float32)
        conv = Conv3x3(rng.normal(size=(cout, cin, 3, 3)).astype(np.float32), rng.normal(size=cout).astype(np.float32))
        residual = rng.random((13, 17, cout), dtype=np.float32)
        assert np.array_equal(conv3x3_planar(x, conv.weight, conv.bias), conv3x3(x, conv.weight, conv.bias))
        conv_call = call({"x": x, "residual": residual, "weights": conv}, layer_uniforms(cin, cout, epilogue))
        expected = ReferencePasses().run_pass("conv3x3_pass", conv_call)
        np.testing.assert_array_equal(FastReferencePasses().run_pass("conv3x3_pass", conv_call)["y"], expected["y"])
    with pytest.raises(ValueError, match="epilogue"):
        FastReferencePasses().run_pass("conv3x3_pass", call({"x": x, "weights": conv}, {"u_epilogue": 7}))


@pytest.mark.parametrize("rows", [1, 2, 5])
def test_fast_gpu_conv3x3_in_blocks_of_rows_equals_reference(monkeypatch, rows):
    from mnss_kit.emulate import fast_gpu
    from mnss_kit.ops.inpaint import conv3x3

    rng = np.random.default_rng(rows)
    x = rng.normal(size=(11, 9, 5)).astype(np.float32)
    weight, bias = rng.normal(size=(4, 5, 3, 3)).astype(np.float32), rng.normal(size=4).astype(np.float32)
    monkeypatch.setattr(fast_gpu, "_BLOCK_VALUES", rows * 4 * 9)
    assert np.array_equal(fast_gpu.conv3x3_planar(x, weight, bias), conv3x3(x, weight, bias))


def test_fast_gpu_passes_equal_reference_on_a_frame_sequence():
    """The whole GPU stage (inpainting weights included) through the fast passes, frame after frame."""
    from mnss_kit.emulate.fast_gpu import FastReferencePasses
    from mnss_kit.model.mnss import gpu_stage as schedule
    from mnss_kit.gpu.reference import ReferencePasses
    from mnss_kit.gpu.weights import Conv3x3
    from mnss_kit.model.mnss.gpu_stage import GpuWeights

    rng = np.random.default_rng(5)
    h, w, s = 10, 14, 2

    def conv(cout, cin):
        weight = rng.normal(size=(cout, cin, 3, 3)).astype(np.float32) * 0.3
        return Conv3x3(weight, rng.normal(size=cout).astype(np.float32) * 0.1)

    weights = GpuWeights(inpaint=conv(1, 4), aa=(conv(8, 6), conv(3, 8)))
    stage = schedule.GpuStage(s, True, "sigmoid", "bilinear", None, weights)
    boundary = schedule.NpuBoundary(1 / 255, -128, 1 / 255, -128)
    states = {"fast": None, "reference": None}
    for t in range(3):
        frame = {"color": rng.random((h, w, 3), dtype=np.float32), "depth": rng.random((h, w, 1), dtype=np.float32),
                 "motion": rng.normal(size=(h, w, 2)).astype(np.float32), "jitter": np.float32([0.25, -0.25]) * (-1) ** t,
                 "reset": False}
        out = {}
        for name, passes in (("fast", FastReferencePasses()), ("reference", ReferencePasses())):
            out[name] = schedule.before_npu(passes, stage, frame, states[name], boundary)
            history = np.clip(out[name]["rectified"] + 0.01, 0, 1)
            states[name] = schedule.next_state(frame, history)
        for key in ("npu_input", "lr_weight", "rectified", "aa"):
            if out["reference"][key] is not None:
                np.testing.assert_array_equal(out["fast"][key], out["reference"][key], err_msg=f"frame {t} {key}")
