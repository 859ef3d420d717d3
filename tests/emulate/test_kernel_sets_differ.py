"""The kernel-set choice is real, and the fast convolution is exact.

A chain of 3x3 convolutions run layer by layer through LiteRT gives different
int8 outputs under the reference kernels and XNNPACK; the emulator follows
each of them exactly.  The im2col/float-matmul accumulation equals a plain
int64 loop at the largest operand values, on both sides of the float32
exactness bound.
"""

from __future__ import annotations

import numpy as np
import pytest

from litert_ops import PADDING, OneOpRunner, TensorSpec, single_op_model

from mnss_kit.emulate import kernels

pytest.importorskip("ai_edge_litert")

CHAIN_DEPTH = 8
CHANNELS = 16


def make_chain(rng: np.random.Generator):
    """Layers of a conv chain with scales a PTQ calibration would give (not tie-prone)."""
    layers, s_in = [], np.float32(0.02)
    for _ in range(CHAIN_DEPTH):
        w_float = rng.standard_normal((CHANNELS, 3, 3, CHANNELS)).astype(np.float32) * 0.08
        w_scales = (np.abs(w_float).reshape(CHANNELS, -1).max(axis=1) / 127).astype(np.float32)
        weights = np.clip(np.round(w_float / w_scales[:, None, None, None]), -127, 127).astype(np.int8)
        bias = rng.integers(-500, 500, CHANNELS).astype(np.int32)
        out_q = (np.float32(s_in * rng.uniform(1.5, 2.5)), int(rng.integers(-20, 20)))
        layers.append(dict(weights=weights, w_scales=w_scales, bias=bias, out_q=out_q))
        s_in = out_q[0]
    return layers


def litert_layer(x: np.ndarray, x_q, layer, kernel_set: str) -> np.ndarray:
    co = layer["weights"].shape[0]
    inputs = [TensorSpec(x.shape, "int8", [x_q[0]], [x_q[1]]),
              TensorSpec(layer["weights"].shape, "int8", layer["w_scales"], [0] * co, 0, layer["weights"]),
              TensorSpec((co,), "int32", (layer["w_scales"] * np.float32(x_q[0])).astype(np.float32), [0] * co, 0, layer["bias"])]
    out = TensorSpec(x.shape[:3] + (co,), "int8", [layer["out_q"][0]], [layer["out_q"][1]])
    model = single_op_model("CONV_2D", inputs, [out], dict(padding=PADDING["SAME"], strideW=1, strideH=1))
    return OneOpRunner(model, kernel_set)(x)[0]


def run_chain(x, x_q, layers, kernel_set: str, litert: bool) -> np.ndarray:
    for layer in layers:
        if litert:
            x = litert_layer(x, x_q, layer, kernel_set)
        else:
            x = kernels.conv2d(x, x_q, layer["weights"], layer["w_scales"], layer["bias"], layer["out_q"],
                               padding="SAME", runtime=kernel_set)
        x_q = layer["out_q"]
    return x


def test_deep_conv_chain_differs_between_reference_and_xnnpack():
    rng = np.random.default_rng(7)
    layers = make_chain(rng)
    x = rng.integers(-128, 128, (1, 24, 24, CHANNELS)).astype(np.int8)
    x_q = (np.float32(0.02), 0)
    outputs = {}
    for kernel_set in ("tflite-ref", "xnnpack"):
        emulated = run_chain(x, x_q, layers, kernel_set, litert=False)
        np.testing.assert_array_equal(emulated, run_chain(x, x_q, layers, kernel_set, litert=True))
        outputs[kernel_set] = emulated
    differ = outputs["tflite-ref"] != outputs["xnnpack"]
    assert differ.any(), "reference and XNNPACK agree after a deep chain: the profile choice would not matter"
    one_layer = kernels.conv2d(x, x_q, **{k: layers[0][k] for k in ("weights", "w_scales", "bias", "out_q")}, runtime="xnnpack")
    one_layer_ref = kernels.conv2d(x, x_q, **{k: layers[0][k] for k in ("weights", "w_scales", "bias", "out_q")})
    assert differ.mean() > (one_layer != one_layer_ref).mean(), "differences should compound with depth"


@pytest.mark.parametrize("channels", [8, 57, 64])  # K = 72, 513 (float32 path) and 576 (float64 path)
def test_conv_accumulators_exact_at_extremes(channels):
    rng = np.random.default_rng(channels)
    x = np.where(rng.random((1, 5, 5, channels)) < 0.5, -128, 127).astype(np.int8)
    weights = np.where(rng.random((4, 3, 3, channels)) < 0.5, -128, 127).astype(np.int8)
    x_zero_point = 127
    fast = kernels.conv_accumulators(x, x_zero_point, weights, None, stride=1, padding="VALID")
    centred = x.astype(np.int64) - x_zero_point
    slow = np.zeros(fast.shape, dtype=np.int64)
    for i in range(3):
        for j in range(3):
            slow += np.einsum("nhwc,oc->nhwo", centred[:, i:i + 3, j:j + 3], weights[:, i, j].astype(np.int64))
    np.testing.assert_array_equal(fast, slow)


def test_depth_space_round_trip_and_pad():
    x = np.arange(2 * 4 * 6 * 8, dtype=np.int64).astype(np.int8).reshape(2, 4, 6, 8)
    np.testing.assert_array_equal(kernels.depth_to_space(kernels.space_to_depth(x, 2), 2), x)
    padded = kernels.pad(x, [[0, 0], [1, 2], [0, 1], [0, 0]], zero_point=-7)
    assert padded.shape == (2, 7, 7, 8) and padded.dtype == np.int8
    assert (padded[:, 0] == -7).all() and (padded[:, -2:] == -7).all() and (padded[:, :, -1] == -7).all()
