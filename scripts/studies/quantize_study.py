#!/usr/bin/env python
"""int8 study of one checkpoint: every range method, with and without A16, fp32 vs int8 on held-out data.

    python scripts/studies/quantize_study.py --model mnss_x2 --calib data/train_x2 --data data/test_x2
    python scripts/studies/quantize_study.py --doc-only    # regenerate docs/studies/quantization.md from the JSON files

Calibration samples are recorded once (``mnss-kit quantize``'s recurrent
recording, spread over the calibration sequences) and shared by every
setting.  All settings are then evaluated in one run of
``mnss_kit.eval.loop.evaluate`` (the code behind ``mnss-kit eval``) next to the
float model, so every frame is paired.  The quality numbers are deterministic
(one run); the latencies are medians of interleaved runs.  Writes
``benchmarks/results/quantize_study.json`` and generates ``docs/studies/quantization.md``
with its charts from that file and from ``scripts/studies/int8_drift.py``'s JSON.
"""

from __future__ import annotations

import argparse
import logging
import platform
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from mnss_kit.fileio import atomic_output_path, atomic_write_json, atomic_write_text, portable_command, portable_path  # noqa: E402
from mnss_kit.model.families import npu_module  # noqa: E402
from mnss_kit.ops.runtimes import DEFAULT_RUNTIME, get_runtime, runtime_names  # noqa: E402

STUDY_JSON = REPO / "benchmarks" / "results" / "quantize_study.json"
DRIFT_JSON = REPO / "benchmarks" / "results" / "int8_drift.json"
DOC = REPO / "docs" / "studies" / "quantization.md"
METHODS = ("minmax", "percentile", "entropy", "mse")
# the target: int8 loses at most 0.2 dB PSNR and at most 0.002 IF-SSIM against fp32 (delta = int8 - fp32)
TARGET = {"psnr": -0.2, "if_ssim": -0.002}


# The page's opening line: what the reader can do with it.
LEAD = "This page records what int8 costs `mnss_x2` under each calibration method, how LiteRT and ONNX Runtime agree, and whether the error drifts over a long recurrent run."


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="mnss_x2", help="checkpoint path or shipped model name (default mnss_x2)")
    parser.add_argument("--calib", type=Path, help="calibration dataset (training-like data)")
    parser.add_argument("--data", type=Path, help="held-out dataset for fp32 vs int8")
    parser.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    parser.add_argument("--a16", nargs="+", type=int, default=[0, 2], metavar="N", help="A16 tensor counts to try (default 0 2)")
    parser.add_argument("--frames", type=int, default=24, help="calibration samples (default 24, as mnss-kit quantize)")
    parser.add_argument("--max-frames", type=int, help="frames per held-out sequence (default: all)")
    parser.add_argument("--runtime", choices=runtime_names("litert"), default="xnnpack",
                        help="LiteRT kernels that run the int8 stage in the evaluation (default xnnpack; reference is ~50x slower)")
    parser.add_argument("--check-runtime", choices=runtime_names("litert"), default=DEFAULT_RUNTIME,
                        help="also run the first setting with these kernels, to show what the kernel choice changes (default reference)")
    parser.add_argument("--repeats", type=int, default=10, help="latency runs per setting (median)")
    parser.add_argument("--agreement-samples", type=int, default=4, help="calibration samples for the runtime-agreement study")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (LiteRT and ONNX Runtime use 1)")
    parser.add_argument("--json", type=Path, default=STUDY_JSON)
    parser.add_argument("--drift-json", type=Path, default=DRIFT_JSON)
    parser.add_argument("--doc", type=Path, default=DOC)
    parser.add_argument("--doc-only", action="store_true", help="only regenerate the document from the JSON files")
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    if not args.doc_only:
        if args.calib is None or args.data is None:
            parser.error("--calib and --data are required unless --doc-only")
        atomic_write_json(args.json, plain(measure(args, argv if argv is not None else sys.argv[1:])))
        print(f"wrote {args.json}")
    write_doc(args.json, args.drift_json, args.doc)
    print(f"wrote {args.doc}")
    return 0


def setting_name(method: str, a16: int) -> str:
    return f"{method}" if a16 == 0 else f"{method}+a16x{a16}"


def measure(args, argv: list[str]) -> dict:
    import torch

    from mnss_kit.model.checkpoint import load
    from mnss_kit.quantize.run import calibration_samples, evaluate_int8, evaluation_info, fp32_vs_int8, open_data
    from mnss_kit.quantize.stage import QuantizeOptions, quantize_module

    torch.set_num_threads(args.threads)
    progress = not args.no_progress
    model, record = load(args.model)
    model.eval()
    open_data(args.data, model.scale, role="evaluation")
    samples = calibration_samples(model, open_data(args.calib, model.scale), args.frames, progress=progress)
    arts, requested = {}, {}
    for method in args.methods:
        for a16 in args.a16:
            name = setting_name(method, a16)
            logging.info("quantizing: %s", name)
            arts[name] = quantize_module(npu_module(model), samples, QuantizeOptions(method=method, int16=a16), name=name)
            requested[name] = a16
    first = next(iter(arts.values()))
    logging.info("runtime agreement of %s", first.report["model"])
    agreement = {"setting": first.report["model"], **lsb_study(first.graph, first.tflite, samples[: args.agreement_samples])}
    variants = {name: (art, args.runtime) for name, art in arts.items()}
    check = None
    if args.check_runtime and args.check_runtime != args.runtime:  # the same int8 graph under another kernel set
        check = f"{first.report['model']}@{args.check_runtime}"
        variants[check] = (first, args.check_runtime)
    result = evaluate_int8(model, variants, args.data, args.max_frames, progress=progress)
    latency, fp32_latency = measure_latency(model, arts, samples[0], args.repeats)
    settings = []
    for name, art in arts.items():
        cmp = fp32_vs_int8(result, name)
        settings.append({
            "setting": name,
            "method": art.report["method"],
            "a16": requested[name],
            "int16_tensors": art.report["int16"],
            "int16_skipped": art.report["int16_skipped"],
            "fp32": cmp["fp32"], "int8": cmp["int8"], "delta": cmp["delta"],
            "sequences": cmp["sequences"],
            "meets_target": meets_target(cmp["delta"]),
            "stage_output_psnr_db": art.report["output"]["tflite-ref"]["psnr_db"],
            "agreement_end_to_end_max_lsb": art.report["agreement"]["end_to_end_max_lsb"],
            "agreement_per_op_max_lsb": art.report["agreement"]["per_op_max_lsb"],
            "tflite_bytes": len(art.tflite),
            "latency_ms": latency[name],
        })
    return {
        "study": "quantize",
        "command": "python scripts/studies/quantize_study.py " + portable_command(argv),
        "checkpoint": {"name": args.model, "family": record.get("family"), "config": record.get("config"),
                       "training": record.get("training"), "code_version": record.get("code_version")},
        "calibration": {"data": portable_path(args.calib), "samples": len(samples), "recording": "recurrent float runs, spread over every sequence"},
        "evaluation": evaluation_info(result, args.runtime, held_out=True, data_label=portable_path(args.data)),
        "target": {"delta_psnr_db_at_least": TARGET["psnr"], "delta_if_ssim_at_least": TARGET["if_ssim"]},
        "latency": {"runtime": "xnnpack (LiteRT AUTO), 1 thread, this CPU", "input_nhwc": nhwc_shape(samples[0][0]),
                    "repeats": args.repeats, "statistic": "median of interleaved runs", "fp32_ms": fp32_latency,
                    "note": "int16 activations have no XNNPACK kernels; those ops fall back to LiteRT builtin kernels"},
        "settings": settings,
        "agreement": agreement,
        "runtime_check": None if check is None else {
            "setting": first.report["model"], "runtimes": [args.runtime, args.check_runtime],
            "int8": {args.runtime: fp32_vs_int8(result, first.report["model"])["int8"],
                     args.check_runtime: fp32_vs_int8(result, check)["int8"]},
        },
        "machine": {"platform": platform.platform(), "python": platform.python_version()},
    }


def nhwc_shape(nchw) -> list[int]:
    n, c, h, w = nchw.shape
    return [n, h, w, c]


def meets_target(delta: dict) -> bool:
    return all(delta[k] is not None and delta[k] >= limit for k, limit in TARGET.items())


def measure_latency(model, arts: dict, sample, repeats: int) -> tuple[dict, float]:
    """Median ms per call of each setting's npu.tflite and of the fp32 stage, XNNPACK, interleaved."""
    import numpy as np
    import torch

    from mnss_kit.bench.latency import interleaved_medians
    from mnss_kit.quantize.runtime import TfliteRunner, quantize_inputs
    from mnss_kit.quantize.tflite_writer import to_tflite
    from mnss_kit.quantize.trace import trace

    float_graph = trace(npu_module(model), [torch.from_numpy(np.asarray(x, np.float32)) for x in sample])
    calls = {"fp32": _call(TfliteRunner(to_tflite(float_graph), "xnnpack"), [np.ascontiguousarray(np.transpose(x, (0, 2, 3, 1))) for x in sample])}
    for name, art in arts.items():
        calls[name] = _call(TfliteRunner(art.tflite, "xnnpack"), quantize_inputs(art.graph, list(sample), "xnnpack"))
    seconds = interleaved_medians(calls, repeats, warmup=2)
    ms = {k: v * 1e3 for k, v in seconds.items()}
    return {k: v for k, v in ms.items() if k != "fp32"}, ms["fp32"]


def lsb_study(graph, tflite: bytes, samples) -> dict:
    """Whole-graph differences, in LSB of each int8 tensor, between LiteRT kernel sets and ONNX Runtime QDQ.

    Per tensor (LiteRT reference vs ONNX Runtime): the whole-graph difference;
    ``alone``: the producing op run alone by LiteRT reference on ONNX Runtime's
    own values of its inputs, against ONNX Runtime's output (what the op adds
    by itself; the rest is inherited from upstream); for convolutions, how
    many of those per-op differences lie in the double-rounding window of the
    reference kernels (exact value within 2^-(n+1) of a .5 tie, n the
    channel's right shift), and ``input_lsb_gain``, by how many output LSB one
    input LSB can move an output (largest weight times s_in s_w / s_out).
    """
    import numpy as np

    from mnss_kit.ops.int8.conv import conv2d_accumulate
    from mnss_kit.ops.int8.multiplier import effective_multiplier, quantize_multiplier
    from mnss_kit.quantize.graph import conv_pads, op_graph
    from mnss_kit.quantize.onnx_writer import to_onnx
    from mnss_kit.quantize.runtime import OnnxRunner, TfliteRunner, quantize_inputs
    from mnss_kit.quantize.tflite_writer import to_tflite

    names = [n for n in graph.activations() if graph.tensors[n].dtype == "int8"]
    runners = {r: TfliteRunner(tflite, r, preserve_all=True) for r in runtime_names("litert")}
    ort = OnnxRunner(to_onnx(graph, expose=graph.activations()))
    alone_runners = {op.outputs[0]: TfliteRunner(to_tflite(op_graph(graph, op)), "tflite-ref") for op in graph.ops}
    pairs: dict[str, int] = {}
    rows = {n: {"tensor": n, "op": (graph.producer(n).kind if graph.producer(n) else "INPUT"), "whole_graph_max_lsb": 0,
                "differing": 0, "values": 0, "alone_max_lsb": 0} for n in names}
    for sample in samples:
        q = quantize_inputs(graph, list(sample))
        outs = {k: r.run(q, names) for k, r in runners.items()}
        outs["ort-cpu"] = ort.run(q)
        keys = list(outs)
        for i, a in enumerate(keys):
            for b in keys[i + 1:]:
                worst = max(_lsb(outs[a][n], outs[b][n]).max() for n in names)
                pairs[f"{a} vs {b}"] = max(pairs.get(f"{a} vs {b}", 0), int(worst))
        ref, onnx = outs["tflite-ref"], outs["ort-cpu"]
        for op in graph.ops:
            out = op.outputs[0]
            if out not in rows:
                continue
            d = _lsb(ref[out], onnx[out])
            row = rows[out]
            row["whole_graph_max_lsb"] = max(row["whole_graph_max_lsb"], int(d.max()))
            row["differing"] += int(np.count_nonzero(d))
            row["values"] += d.size
            sub_inputs = [onnx[n] for n in op_graph(graph, op).inputs]
            alone = alone_runners[out].run(sub_inputs)[out]
            da = _lsb(alone, onnx[out])
            row["alone_max_lsb"] = max(row["alone_max_lsb"], int(da.max()))
            if op.kind == "CONV_2D":
                x, w, bias = (graph.tensors[n] for n in op.inputs[:3])
                o = graph.tensors[out]
                acc = conv2d_accumulate(sub_inputs[0], x.zero_point, w.data, bias.data, padding=conv_pads(graph, op))
                real = effective_multiplier(x.scale, w.scale, o.scale, get_runtime("tflite-ref"))
                pairs_q31 = [quantize_multiplier(float(r)) for r in real]
                mult = np.array([m * 2.0 ** (sh - 31) for m, sh in pairs_q31])
                right = np.array([max(-sh, 0) for _, sh in pairs_q31])
                exact = acc * mult
                to_tie = np.abs(exact - np.floor(exact) - 0.5)
                window = to_tie <= 2.0 ** -(right + 1)
                row["alone_differing"] = row.get("alone_differing", 0) + int(np.count_nonzero(da))
                row["alone_in_double_rounding_window"] = row.get("alone_in_double_rounding_window", 0) + int(np.count_nonzero((da > 0) & window))
                row["right_shift_range"] = [int(right.min()), int(right.max())]
                wmax = np.abs(w.data.astype(np.int64)).reshape(w.data.shape[0], -1).max(axis=1)
                row["input_lsb_gain"] = float((wmax * real).max())
    for row in rows.values():
        row["fraction_differing"] = row.pop("differing") / max(row.pop("values"), 1)
    return {"samples": len(samples), "whole_graph_max_lsb": pairs, "tensors": list(rows.values())}


def _lsb(a, b):
    import numpy as np

    return np.abs(a.astype(np.int64) - b.astype(np.int64))


def _call(runner, inputs):
    return lambda: runner.run(inputs)


def plain(value):
    """JSON-safe copy (NaN and infinities to None)."""
    import math

    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if hasattr(value, "item"):
        return plain(value.item())
    return value


# ---------------------------------------------------------------------------
# docs/studies/quantization.md


def write_doc(study_path: Path, drift_path: Path, doc: Path) -> None:
    import json

    study = json.loads(study_path.read_text()) if study_path.is_file() else None
    drift = json.loads(drift_path.read_text()) if drift_path.is_file() else None
    parts = [
        "# int8 quantization: accuracy, speed and drift",
        "",
        LEAD,
        "",
        f"Generated by `scripts/studies/quantize_study.py` from `{_rel(study_path)}` and `scripts/studies/int8_drift.py` from `{_rel(drift_path)}`; "
        "do not edit by hand.  Every number below comes from those files.",
        "",
        f"Target: int8 loses at most {-TARGET['psnr']:.1f} dB PSNR and at most {-TARGET['if_ssim']:.3f} IF-SSIM against fp32 "
        "on the held-out sequences (delta = int8 - fp32, so a setting meets it when delta PSNR >= "
        f"{TARGET['psnr']} and delta IF-SSIM >= {TARGET['if_ssim']}).",
        "",
    ]
    if study:
        parts += study_section(study, doc)
    else:
        parts += ["No study results yet: run `scripts/studies/quantize_study.py`.", ""]
    if drift:
        parts += drift_section(drift, doc)
    else:
        parts += ["## Drift over 1000 recurrent frames", "", "No drift results yet: run `scripts/studies/int8_drift.py`.", ""]
    atomic_write_text(doc, "\n".join(parts))


def _rel(path: Path) -> str:
    try:
        return str(Path(path).resolve().relative_to(REPO))
    except ValueError:
        return str(path)


def study_section(study: dict, doc: Path) -> list[str]:
    ev, ck, lat = study["evaluation"], study["checkpoint"], study["latency"]
    chart = doc.with_name(doc.stem + "_tradeoff.png")
    tradeoff_chart(study, chart)
    met = [s["setting"] for s in study["settings"] if s["meets_target"]]
    out = [
        "## fp32 vs int8 per calibration setting",
        "",
        f"Reproduce: `{study['command']}`",
        "",
        f"Checkpoint `{ck['name']}` ({ck['family']}, code {ck['code_version']}).  Calibration: {study['calibration']['samples']} "
        f"NPU-stage inputs from {study['calibration']['recording']} of `{study['calibration']['data']}`.  "
        f"Evaluation: {ev['evaluator']}; {ev['sequences']} held-out sequences of `{ev['data']}`, "
        f"{'all frames' if ev['max_frames_per_sequence'] is None else 'at most %d frames' % ev['max_frames_per_sequence']} per sequence, "
        f"{ev['frames']} frames in all.  GPU part: {ev['gpu_part']}.  int8 NPU stage: `npu.tflite` run by {ev['int8_runtime']}.  "
        f"fp32 and every int8 setting ran side by side in one pass.",
        "",
        f"**Meets the target: {', '.join(met) if met else 'none of the settings'}.**",
        "",
        "| setting | 16-bit tensors | fp32 PSNR | int8 PSNR | delta PSNR (dB) | delta SSIM | delta IF-SSIM | stage PSNR vs float (dB) | "
        "ref vs ORT max LSB | npu.tflite bytes | latency ms | target |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in study["settings"]:
        d = s["delta"]
        out.append(
            f"| {s['setting']} | {', '.join(s['int16_tensors']) or '-'} | {s['fp32']['psnr']:.3f} | {s['int8']['psnr']:.3f} | {d['psnr']:+.3f} | "
            f"{d['ssim']:+.5f} | {d['if_ssim']:+.5f} | {s['stage_output_psnr_db']:.2f} | {s['agreement_end_to_end_max_lsb']} | "
            f"{s['tflite_bytes']} | {s['latency_ms']:.1f} | {'yes' if s['meets_target'] else 'no'} |"
        )
    check = study.get("runtime_check")
    if check:
        (ra, a), (rb, b) = check["int8"].items()
        out += ["", f"Kernel choice: the `{check['setting']}` graph run by {rb} instead of {ra} in the same pass: int8 PSNR "
                f"{b['psnr']:.4f} vs {a['psnr']:.4f} dB ({b['psnr'] - a['psnr']:+.4f}), IF-SSIM {b['if_ssim']:.5f} vs {a['if_ssim']:.5f} "
                f"({b['if_ssim'] - a['if_ssim']:+.6f})."]
    skipped = {n: r for s in study["settings"] for n, r in (s.get("int16_skipped") or {}).items()}
    if skipped:
        out += ["", "More sensitive tensors passed over for 16 bits: " + "; ".join(f"`{n}`: {r}" for n, r in skipped.items()) + "."]
    a16_effect = a16_change(study["settings"])
    if a16_effect is not None:
        out += ["", f"A16 changes delta PSNR by at most {a16_effect:.4f} dB against the same range method without it."]
    out += [
        "",
        f"fp32 IF-SSIM {study['settings'][0]['fp32']['if_ssim']:.5f}.  Stage PSNR vs float: the int8 stage's output against the float "
        "stage on the calibration samples (LiteRT reference kernels).  ref vs ORT: largest difference, in LSB, between LiteRT "
        "reference and ONNX Runtime QDQ on any int8 tensor of the whole graph on the same inputs.  Latency: the NPU stage alone, "
        f"{lat['runtime']}, input {'x'.join(map(str, lat['input_nhwc']))} NHWC, {lat['statistic']} of {lat['repeats']}; fp32 stage "
        f"{lat['fp32_ms']:.1f} ms in the same run ({lat['note']}).  Desktop CPU latency, not a phone's NPU: compare ratios.",
        "",
        f"![int8 loss vs NPU-stage latency]({chart.name})",
        "",
        "### delta PSNR per held-out sequence (dB)",
        "",
    ]
    seqs = [p["sequence"] for p in study["settings"][0]["sequences"]]
    out += ["| setting | " + " | ".join(seqs) + " |", "|---|" + "---|" * len(seqs)]
    for s in study["settings"]:
        out.append(f"| {s['setting']} | " + " | ".join(f"{p['delta']['psnr']:+.3f}" for p in s["sequences"]) + " |")
    out += ["", "### delta IF-SSIM per held-out sequence", "", "| setting | " + " | ".join(seqs) + " |", "|---|" + "---|" * len(seqs)]
    for s in study["settings"]:
        out.append(f"| {s['setting']} | " + " | ".join(_signed(p["delta"]["if_ssim"], 5) for p in s["sequences"]) + " |")
    return out + [""] + agreement_section(study["agreement"])


def agreement_section(agreement: dict) -> list[str]:
    out = [
        f"## LiteRT vs ONNX Runtime QDQ, bit level ({agreement['setting']})",
        "",
        f"The same `npu.tflite` / `npu_qdq.onnx` pair (same scales and zero points by construction) on {agreement['samples']} "
        "calibration samples, same integer inputs.  Largest difference over every int8 tensor of the whole graph:",
        "",
        "| runtimes | whole-graph max LSB |",
        "|---|---|",
    ]
    out += [f"| {pair} | {lsb} |" for pair, lsb in agreement["whole_graph_max_lsb"].items()]
    out += [
        "",
        "Per tensor, LiteRT reference kernels vs ONNX Runtime.  *alone*: the producing op run by itself in LiteRT reference on "
        "ONNX Runtime's own input values, against ONNX Runtime's output: what the op contributes; anything above it in the "
        "whole-graph column is inherited from upstream differences.  *in window*: per-op differences whose exact value "
        "lies within 2^-(n+1) of a .5 tie (n: the channel's right shift), where the reference kernels' two roundings "
        "(high multiply, then rounding shift) can disagree with ONNX Runtime's single float32 rounding.  *gain*: output LSB "
        "moved by one input LSB through the largest weight.",
        "",
        "| tensor | op | whole graph max LSB | values differing | alone max LSB | alone differing, in window | right shifts | gain |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for t in agreement["tensors"]:
        window = f"{t['alone_differing']}, {t['alone_in_double_rounding_window']}" if "alone_differing" in t else "-"
        shifts = "-" if "right_shift_range" not in t else "{}-{}".format(*t["right_shift_range"])
        gain = f"{t['input_lsb_gain']:.2f}" if "input_lsb_gain" in t else "-"
        out.append(f"| {t['tensor']} | {t['op']} | {t['whole_graph_max_lsb']} | {t['fraction_differing']:.4%} | {t['alone_max_lsb']} | "
                   f"{window} | {shifts} | {gain} |")
    return out + [""]


def a16_change(settings: list[dict]) -> float | None:
    """Largest |delta PSNR with A16 - delta PSNR without| over the range methods measured both ways."""
    base = {s["method"]: s["delta"]["psnr"] for s in settings if s["a16"] == 0}
    changes = [abs(s["delta"]["psnr"] - base[s["method"]]) for s in settings if s["a16"] > 0 and s["method"] in base]
    return max(changes) if changes else None


def _signed(v, digits: int) -> str:
    return "-" if v is None else f"{v:+.{digits}f}"


def tradeoff_chart(study: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), dpi=100)
    colours = dict(zip(METHODS, ("#1b9e77", "#d95f02", "#7570b3", "#e7298a")))
    for ax, key, label in ((axes[0], "psnr", "delta PSNR, int8 - fp32 (dB)"), (axes[1], "if_ssim", "delta IF-SSIM, int8 - fp32")):
        ax.scatter([study["latency"]["fp32_ms"]], [0.0], marker="*", s=120, color="black", label="fp32")
        for s in study["settings"]:
            hollow = s["a16"] > 0
            ax.scatter([s["latency_ms"]], [s["delta"][key]], s=50, marker="s" if hollow else "o",
                       facecolors="none" if hollow else colours[s["method"]], edgecolors=colours[s["method"]], label=s["setting"])
        ax.set_xscale("log")
        ax.axhline(TARGET[key], color="grey", linestyle="--", linewidth=1, label="target")
        ax.set_xlabel("NPU-stage latency, LiteRT XNNPACK on this CPU (ms, log)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, loc="lower right")
    fig.suptitle("int8 accuracy loss vs speed (filled: all int8; hollow squares: A16W8)", fontsize=10)
    fig.tight_layout()
    with atomic_output_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def drift_section(drift: dict, doc: Path) -> list[str]:
    chart = doc.with_name(doc.stem + "_drift.png")
    drift_chart(drift, chart)
    w, loop = drift["windows"], drift["loop"]
    out = [
        f"## Drift over {drift['frames']} recurrent frames",
        "",
        f"Reproduce: `{drift['command']}`",
        "",
        f"Sequence `{drift['sequence']}` of `{drift['data']}` ({drift['lr_size'][0]}x{drift['lr_size'][1]} -> "
        f"{drift['hr_size'][0]}x{drift['hr_size'][1]}), played as a ping-pong loop: {loop['description']}  "
        f"Quantization: {drift['quantization']['method']}, {drift['quantization']['a16']} 16-bit tensors, calibrated on "
        f"`{drift['quantization']['calibration_data']}`.  GPU part in PyTorch float32; int8 NPU stage in {drift['int8_runtime']}.  "
        f"PSNR against the HR reference of the source frame shown.",
        "",
        "| frames | fp32 mean PSNR (dB) | int8 mean PSNR (dB) | int8 - fp32 (dB) |",
        "|---|---|---|---|",
    ]
    for key in ("early", "late"):
        a, b = w[key]["first"] + 1, w[key]["last"] + 1
        out.append(f"| {a}-{b} | {w[key]['fp32_psnr']:.3f} | {w[key]['int8_psnr']:.3f} | {w[key]['int8_psnr'] - w[key]['fp32_psnr']:+.3f} |")
    r = drift["result"]
    settled = {n: periodic_from(drift["psnr"][n], loop["period"]) for n in ("fp32", "int8")}
    out += [
        "",
        f"int8, last {w['late']['last'] - w['late']['first'] + 1} frames vs frames {w['early']['first'] + 1}-{w['early']['last'] + 1}: "
        f"{r['int8_drift_db']:+.3f} dB (fp32: {r['fp32_drift_db']:+.3f} dB); the requirement is within {r['tolerance_db']} dB: "
        f"**{'met' if r['int8_within_tolerance'] else 'not met'}**.  Both windows show the same source frames in the same order "
        f"(the loop period, {loop['period']} frames, divides the {w['late']['first'] - w['early']['first']}-frame distance between them).  "
        + _settled_sentence(settled, loop["period"]),
        "",
        f"![PSNR over the recurrent run]({chart.name})",
        "",
    ]
    return out


def periodic_from(values: list[float], period: int, tolerance: float = 1e-6) -> int | None:
    """First frame index from which ``values`` repeat with ``period`` (within ``tolerance``) to the end; None if never."""
    start = None
    for i in range(len(values) - period):
        if abs(values[i] - values[i + period]) > tolerance:
            start = None
        elif start is None:
            start = i
    return start


def _settled_sentence(settled: dict, period: int) -> str:
    """What the periodicity of the per-frame PSNR says about the recurrent state."""
    if any(v is None for v in settled.values()):
        never = [n for n, v in settled.items() if v is None]
        return f"Per-frame PSNR of {' and '.join(never)} never repeats with the loop period (within 1e-6 dB)."
    return (f"Per-frame PSNR repeats with the loop period (within 1e-6 dB) from frame {settled['int8'] + 1} on for int8 and from "
            f"frame {settled['fp32'] + 1} on for fp32: the recurrent state settles into the loop's cycle instead of carrying "
            "error forward.  A loop shows whether error accumulates in the history; it cannot show drift that only new "
            "content would trigger.")


def drift_chart(drift: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 5), dpi=100, sharex=True)
    frames = range(1, len(drift["psnr"]["fp32"]) + 1)
    top.plot(frames, drift["psnr"]["fp32"], linewidth=0.7, label="fp32")
    top.plot(frames, drift["psnr"]["int8"], linewidth=0.7, label="int8")
    top.set_ylabel("PSNR vs reference (dB)")
    top.legend(fontsize=8)
    gap = [b - a for a, b in zip(drift["psnr"]["fp32"], drift["psnr"]["int8"])]
    bottom.plot(frames, gap, linewidth=0.7, color="#d95f02")
    bottom.axhline(0.0, color="grey", linewidth=0.5)
    bottom.set_ylabel("int8 - fp32 (dB)")
    bottom.set_xlabel("frame of the recurrent run")
    for ax in (top, bottom):
        for key in ("early", "late"):
            ax.axvspan(drift["windows"][key]["first"] + 1, drift["windows"][key]["last"] + 1, color="grey", alpha=0.12)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    with atomic_output_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
