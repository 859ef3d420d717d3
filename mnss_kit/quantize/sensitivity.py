"""Per-tensor sensitivity of the quantized NPU stage, and the choice of tensors for 16-bit activations.

Two views, both measured against the float graph on the same samples:

``sqnr_db``        SQNR of each quantized tensor (dequantized, LiteRT reference
                   kernels, everything quantized) against its float value: where
                   error accumulates.
``only_psnr_db``   output PSNR when only that tensor (and its producer's
                   weights) is quantized and the rest stays float: which
                   tensor's own rounding hurts the output most.

PSNR uses peak 1.0: the stage's outputs are display values in [0, 1].
Everything is accumulated sample by sample, so full-resolution frames fit in
memory.
"""

from __future__ import annotations

import numpy as np

from ..metrics.psnr import psnr
from .graph import Graph
from .params import int16_blocker


def power_ratio_db(signal: float, noise: float) -> float:
    """SQNR in dB from summed signal and noise powers; ``inf`` without noise.

    A ratio of powers, not PSNR's peak over MSE (``metrics.psnr``); numpy's log10, as the
    quantize reports have always been computed.
    """
    return float("inf") if noise == 0.0 else 10.0 * np.log10(max(signal, 1e-30) / noise)


def sqnr_db(reference: np.ndarray, approx: np.ndarray) -> float:
    """``10 log10(sum ref^2 / sum (ref - approx)^2)``; inf when equal."""
    noise = float(np.sum((np.asarray(reference, np.float64) - approx) ** 2))
    signal = float(np.sum(np.asarray(reference, np.float64) ** 2))
    return power_ratio_db(signal, noise)


def tensor_sqnr(float_graph: Graph, quantized: Graph, model: bytes, samples) -> tuple[dict[str, float], list[dict[str, np.ndarray]]]:
    """SQNR (dB) of every quantized activation against the float graph (LiteRT reference kernels).

    Conversion tensors of 16-bit activations have no float counterpart and are
    skipped.  Also returns the float graph's outputs per sample
    (``{name: NHWC array}``) for the output measurements.
    """
    from .calibrate import float_activations
    from .runtime import TfliteRunner, dequantize_tensor, quantize_inputs

    names = [n for n in quantized.activations() if n in float_graph.tensors]
    runner = TfliteRunner(model, "tflite-ref", preserve_all=True)
    signal = dict.fromkeys(names, 0.0)
    noise = dict.fromkeys(names, 0.0)
    outputs = []
    for sample, floats in zip(samples, float_activations(float_graph, samples)):
        q = runner.run(quantize_inputs(quantized, list(sample)), names)
        for n in names:
            ref = floats[n].astype(np.float64)
            signal[n] += float(np.sum(ref**2))
            noise[n] += float(np.sum((ref - dequantize_tensor(quantized, n, q[n])) ** 2))
        outputs.append({n: floats[n] for n in float_graph.outputs})
    sqnr = {n: power_ratio_db(signal[n], noise[n]) for n in names}
    return sqnr, outputs


def only_layer_psnr(quantized: Graph, samples, float_outputs) -> dict[str, float]:
    """Output PSNR (dB, peak 1) with only one activation tensor quantized, for each tensor.

    ``float_outputs``: the float graph's outputs per sample (from :func:`tensor_sqnr`).
    """
    from .onnx_writer import to_onnx
    from .runtime import OnnxRunner

    result = {}
    out = quantized.outputs[0]
    reference = np.concatenate([f[out] for f in float_outputs])
    for name in quantized.activations():
        producer = quantized.producer(name)
        if producer is not None and producer.kind == "QUANTIZE":
            continue  # a 16-bit conversion, not a tensor of the float model
        runner = OnnxRunner(to_onnx(quantized, only={name}))
        got = [runner.run([np.transpose(x, (0, 2, 3, 1)) for x in sample])[out] for sample in samples]
        result[name] = psnr(np.concatenate(got), reference)
    return result


def choose_int16(quantized: Graph, only_psnr: dict[str, float], count: int) -> tuple[list[str], dict[str, str]]:
    """The ``count`` most sensitive tensors (lowest single-layer PSNR) that LiteRT can hold in int16.

    Returns the chosen names and, for the sensitive tensors passed over, the reason.
    """
    chosen, skipped = [], {}
    for name in sorted(only_psnr, key=only_psnr.get):
        if len(chosen) == count:
            break
        reason = int16_blocker(quantized, name)
        if reason is None:
            chosen.append(name)
        else:
            skipped[name] = reason
    return chosen, skipped
