"""Activation ranges for the NPU stage, from inputs recorded on recurrent runs of the float model.

Inputs are recorded with a forward hook on the NPU stage (``model.families.npu_module``) while
the whole float model runs frame after frame, so the history it sees is its
own output, as on the device.  Ranges are computed on the float graph written
as ONNX, whose tensor names are the graph's:

``minmax``      observed minimum and maximum (ONNX Runtime MinMaxCalibrater)
``percentile``  the 0.005 % / 99.995 % points of the histogram (ORT PercentileCalibrater)
``entropy``     KL-divergence threshold (ORT EntropyCalibrater)
``mse``         per tensor, the range whose int8 quantization has the least
                squared error over the observed histogram (grid search)

Percentile and entropy ranges are intersected with the observed range (ORT's
entropy range is symmetric, which would waste half of int8 on a ReLU output).
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import UserError
from ..ops.int8.quantize import choose_qparams, dequantize, quantize
from .graph import Graph

METHODS = ("minmax", "percentile", "entropy", "mse")
PERCENTILE = 99.99
HISTOGRAM_BINS = 2048


class InputRecorder:
    """Forward hook on a module that keeps copies of its inputs, one sample per entry.

    Each entry is a list of float32 NCHW arrays with batch 1, in the module's
    argument order.  Use as a context manager around the float model's run.
    """

    def __init__(self, module, limit: int | None = None):
        self.module = module
        self.limit = limit
        self.samples: list[list[np.ndarray]] = []
        self._handle = None

    def _hook(self, module, args, output):
        arrays = [a.detach().cpu().float().numpy() for a in args]
        for i in range(arrays[0].shape[0]):
            if self.limit is None or len(self.samples) < self.limit:
                self.samples.append([a[i : i + 1].copy() for a in arrays])

    def __enter__(self) -> "InputRecorder":
        self._handle = self.module.register_forward_hook(self._hook)
        return self

    def __exit__(self, *exc):
        self._handle.remove()


def check_samples(graph: Graph, samples: Sequence[Sequence[np.ndarray]]) -> None:
    """UserError unless every sample matches the graph inputs (count, NCHW shape) and is finite."""
    if not samples:
        raise UserError("no calibration samples")
    for i, sample in enumerate(samples):
        if len(sample) != len(graph.inputs):
            raise UserError(f"calibration sample {i} has {len(sample)} inputs, the NPU stage takes {len(graph.inputs)}")
        for name, x in zip(graph.inputs, sample):
            n, h, w, c = graph.tensors[name].shape
            if tuple(x.shape) != (n, c, h, w):
                raise UserError(f"calibration sample {i}: input '{name}' has shape {tuple(x.shape)}, expected {(n, c, h, w)}")
            if not np.all(np.isfinite(x)):
                raise UserError(f"calibration sample {i}: input '{name}' contains NaN or Inf")


def calibrate(graph: Graph, samples: Sequence[Sequence[np.ndarray]], method: str = "minmax") -> dict[str, tuple[float, float]]:
    """Real ``(min, max)`` of every activation of float ``graph`` over ``samples`` (lists of NCHW inputs)."""
    if method not in METHODS:
        raise UserError(f"unknown calibration method '{method}' (one of: {', '.join(METHODS)})")
    check_samples(graph, samples)
    observed = _observe(graph, samples)
    if method == "minmax":
        return observed
    if method == "mse":
        histograms = _histograms(graph, samples, observed)
        return {name: mse_range(histograms[name], observed[name]) for name in observed}
    found = _ort_ranges(graph, samples, method)
    ranges = {}
    for name, (lo, hi) in observed.items():
        olo, ohi = found.get(name, (lo, hi))
        ranges[name] = (max(lo, olo), min(hi, ohi))
    return ranges


def float_activations(graph: Graph, samples):
    """Yield every activation of the float graph per sample, ``{name: NHWC array}`` (via the float ONNX graph)."""
    from .onnx_writer import to_onnx
    from .runtime import FLOAT_GRAPH_OPTIMIZATION, OnnxRunner

    names = graph.activations()
    runner = OnnxRunner(to_onnx(graph, quantize=False, expose=names), level=FLOAT_GRAPH_OPTIMIZATION)
    for sample in samples:
        nhwc = [np.transpose(x, (0, 2, 3, 1)) for x in sample]
        values = runner.run(nhwc)
        values.update(zip(graph.inputs, nhwc))
        yield {n: values[n] for n in names}


def _observe(graph: Graph, samples) -> dict[str, tuple[float, float]]:
    """Observed (min, max) of every activation, accumulated sample by sample."""
    observed: dict[str, tuple[float, float]] = {}
    for values in float_activations(graph, samples):
        for n, v in values.items():
            lo, hi = observed.get(n, (np.inf, -np.inf))
            observed[n] = (min(lo, float(v.min())), max(hi, float(v.max())))
    for n, (lo, hi) in observed.items():
        if not (np.isfinite(lo) and np.isfinite(hi)):
            raise UserError(f"the float model produces NaN or Inf at tensor '{n}' on the calibration data")
    return observed


def _histograms(graph: Graph, samples, observed) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Histogram of every activation over its observed range (a second pass over the samples)."""
    bounds = {n: (lo, hi if hi > lo else lo + 1e-6) for n, (lo, hi) in observed.items()}
    counts = {n: np.zeros(HISTOGRAM_BINS, np.float64) for n in observed}
    for values in float_activations(graph, samples):
        for n, v in values.items():
            counts[n] += np.histogram(v, bins=HISTOGRAM_BINS, range=bounds[n])[0]
    return {n: (counts[n], np.linspace(*bounds[n], HISTOGRAM_BINS + 1)) for n in observed}


def mse_range(histogram: tuple[np.ndarray, np.ndarray], observed: tuple[float, float], steps: int = 41) -> tuple[float, float]:
    """Range ``(a * min, b * max)`` (``a, b`` in [0.2, 1]) minimising the int8 quantization MSE of a histogram.

    The error of each candidate quantizes the bin centres with the same
    parameters the graph would get (:func:`mnss_kit.ops.int8.quantize.choose_qparams`).
    """
    counts, edges = histogram
    centres = ((edges[:-1] + edges[1:]) / 2).astype(np.float32)
    lo, hi = observed
    fractions = np.linspace(0.2, 1.0, steps)
    best, best_err = (lo, hi), np.inf
    for a in fractions if lo < 0 else [1.0]:
        for b in fractions if hi > 0 else [1.0]:
            cand = (lo * a, hi * b)
            scale, zp = choose_qparams(*cand)
            err = float(np.sum(counts * (dequantize(quantize(centres, scale, zp), scale, zp) - centres) ** 2))
            if err < best_err:
                best, best_err = cand, err
    return float(best[0]), float(best[1])


def _ort_ranges(graph: Graph, samples, method: str) -> dict[str, tuple[float, float]]:
    """Ranges from onnxruntime.quantization's calibrators run on the float graph."""
    from onnxruntime.quantization.calibrate import CalibrationDataReader, CalibrationMethod, create_calibrator

    from .onnx_writer import to_onnx

    class Reader(CalibrationDataReader):
        def __init__(self):
            self.items = iter(samples)

        def get_next(self):
            sample = next(self.items, None)
            return None if sample is None else {n: np.asarray(x, np.float32) for n, x in zip(graph.inputs, sample)}

    kind = {"percentile": CalibrationMethod.Percentile, "entropy": CalibrationMethod.Entropy}[method]
    extra = {"symmetric": False}
    if method == "percentile":
        extra.update(percentile=PERCENTILE, num_bins=HISTOGRAM_BINS)
    with tempfile.TemporaryDirectory(prefix="mnss-calib-") as tmp:
        path = Path(tmp) / "float.onnx"
        path.write_bytes(to_onnx(graph, quantize=False).SerializeToString())
        with contextlib.redirect_stdout(io.StringIO()):  # the calibrators print progress to stdout
            calibrator = create_calibrator(path, augmented_model_path=str(Path(tmp) / "augmented.onnx"), calibrate_method=kind, extra_options=extra)
            calibrator.collect_data(Reader())
            data = calibrator.compute_data()
    ranges = {}
    for name in graph.activations():
        if name in data:
            lo, hi = data[name].range_value
            ranges[name] = (float(lo), float(hi))
    return ranges
