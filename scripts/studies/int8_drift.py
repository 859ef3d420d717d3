#!/usr/bin/env python
"""int8 drift over a long recurrent run: a held-out sequence played as a 1000-frame ping-pong loop.

    python scripts/studies/int8_drift.py --model mnss_x2 --calib data/train_x2 --data data/test_x2 --sequence town_test

The loop plays source frames 0..K forward, then K-1..1 backward, and again
(period 2K), with a reset only on the very first frame: the history runs
through every frame, and the motion stays continuous (a camera that moves
back and forth) instead of jumping at a loop point.  A backward step from
frame j+1 to frame j needs the motion of frame j towards frame j+1, which
the dataset does not store; it is the inverse of frame j+1's motion field,
found by the fixed-point iteration ``f(p) = -M_{j+1}(p + f(p))`` (bilinear
sampling).  That is exact for smooth motion and an estimate where surfaces
appear or vanish; fp32 and int8 see the same inputs either way.  K is the
largest index before the sequence's first cut for which the period divides
the distance between the two compared windows, so both windows show the
same source frames in the same order.

The GPU part runs in PyTorch float32, the int8 NPU stage in LiteRT (XNNPACK
by default).  Compares the mean PSNR of the last 100 frames with that of
frames 101-200; writes ``benchmarks/results/int8_drift.json`` and regenerates
``docs/studies/quantization.md`` (``scripts/studies/quantize_study.py``).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from quantize_study import DOC, DRIFT_JSON, STUDY_JSON, plain, write_doc  # noqa: E402  (same folder)

from mnss_kit.fileio import atomic_write_json, portable_command, portable_path  # noqa: E402
from mnss_kit.model.families import npu_module  # noqa: E402
from mnss_kit.ops.runtimes import runtime_names  # noqa: E402

WINDOW = 100  # frames per compared window
TOLERANCE_DB = 0.1


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="mnss_x2", help="checkpoint path or shipped model name (default mnss_x2)")
    parser.add_argument("--calib", type=Path, required=True, help="calibration dataset (training-like data)")
    parser.add_argument("--data", type=Path, required=True, help="held-out dataset holding --sequence")
    parser.add_argument("--sequence", default="town_test", help="held-out sequence to loop (default town_test)")
    parser.add_argument("--frames", type=int, default=1000, help="length of the recurrent run (default 1000)")
    parser.add_argument("--method", default="minmax", choices=("minmax", "percentile", "entropy", "mse"))
    parser.add_argument("--a16", type=int, default=0, help="16-bit activation tensors (default 0)")
    parser.add_argument("--calib-frames", type=int, default=24, help="calibration samples (default 24)")
    parser.add_argument("--runtime", choices=runtime_names("litert"), default="xnnpack",
                        help="LiteRT kernels for the int8 stage (default xnnpack)")
    parser.add_argument("--crop", metavar="WxH", help="centred LR crop (default: full frames)")
    parser.add_argument("--inversion-steps", type=int, default=4, help="fixed-point steps inverting motion for backward playback")
    parser.add_argument("--threads", type=int, default=1, help="torch threads")
    parser.add_argument("--json", type=Path, default=DRIFT_JSON)
    parser.add_argument("--study-json", type=Path, default=STUDY_JSON)
    parser.add_argument("--doc", type=Path, default=DOC)
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    if args.frames < 2 * WINDOW + 100:
        parser.error(f"--frames must be at least {2 * WINDOW + 100}")
    result = run(args)
    result["command"] = "python scripts/studies/int8_drift.py " + portable_command(argv if argv is not None else sys.argv[1:])
    atomic_write_json(args.json, plain(result))
    r = result["result"]
    print(f"int8 drift {r['int8_drift_db']:+.3f} dB, fp32 drift {r['fp32_drift_db']:+.3f} dB "
          f"(last {WINDOW} frames vs frames {WINDOW + 1}-{2 * WINDOW}); within {TOLERANCE_DB} dB: {r['int8_within_tolerance']}")
    write_doc(args.study_json, args.json, args.doc)
    print(f"wrote {args.json} and {args.doc}")
    return 0


def loop_length(usable: int, distance: int) -> int:
    """Largest K <= ``usable - 1`` whose ping-pong period 2K divides ``distance``."""
    for k in range(usable - 1, 0, -1):
        if distance % (2 * k) == 0:
            return k
    raise SystemExit(f"no loop of at most {usable} frames has a period dividing {distance}")


def schedule(k: int, frames: int) -> list[tuple[int, bool]]:
    """``(source frame, played backward)`` for each frame of the run: 0..k, k-1..1, 0..k, ..."""
    out: list[tuple[int, bool]] = []
    while len(out) < frames:
        out += [(j, j == 0 and bool(out)) for j in range(k + 1)]  # a later cycle's frame 0 follows frame 1: backward
        out += [(j, True) for j in range(k - 1, 0, -1)]
    return out[:frames]


def inverse_motion(motion_next, steps: int):
    """Motion of frame j towards frame j+1, ``(h, w, 2)`` LR pixels, from frame j+1's motion towards frame j.

    Solves ``f(p) = -M(p + f(p))`` by fixed-point iteration, M sampled bilinearly (clamp to edge).
    """
    from mnss_kit.ops.warp import warp_bilinear

    f = -motion_next
    for _ in range(steps):
        f = -warp_bilinear(motion_next, f)
    return f


def crop_box(crop: str | None, lr_size: tuple[int, int]) -> tuple[int, int, int, int]:
    """``(x, y, w, h)`` of a centred LR crop (the whole frame without ``crop``)."""
    w, h = lr_size
    if not crop:
        return 0, 0, w, h
    cw, ch = (int(v) for v in crop.lower().split("x"))
    cw, ch = min(cw, w), min(ch, h)
    return (w - cw) // 2, (h - ch) // 2, cw, ch


def load_source(seq_dir: Path, k: int, box, scale: int, inversion_steps: int):
    """Frames 0..k: model inputs (cropped), HR reference images, and the inverted motions for backward steps."""
    import numpy as np
    import torch

    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.frames import iter_frames

    x, y, w, h = box
    frames, references = [], []
    for frame in iter_frames(seq_dir, fmt.read_meta(seq_dir), max_frames=k + 1):
        inputs = {key: (v[..., y : y + h, x : x + w] if v.dim() == 4 else v) for key, v in frame.inputs.items()}
        inputs = {key: v for key, v in inputs.items() if not key.startswith("hr_")}  # MNSS reads LR buffers only
        frames.append(inputs)
        references.append(frame.reference[y * scale : (y + h) * scale, x * scale : (x + w) * scale])
    backward_motion = {}
    for j in range(k):
        nxt = frames[j + 1]["motion"][0].permute(1, 2, 0).numpy()
        inv = inverse_motion(nxt, inversion_steps)
        backward_motion[j] = torch.from_numpy(np.ascontiguousarray(inv.transpose(2, 0, 1))[None])
    return frames, references, backward_motion


def run(args) -> dict:
    import numpy as np
    import torch
    from tqdm import tqdm

    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.methods import model_method
    from mnss_kit.metrics.image import to_image
    from mnss_kit.metrics.psnr import psnr
    from mnss_kit.model.checkpoint import load
    from mnss_kit.quantize.run import calibration_samples, int8_model, open_data
    from mnss_kit.quantize.stage import QuantizeOptions, quantize_module

    torch.set_num_threads(args.threads)
    seq_dir = args.data / args.sequence
    meta = fmt.read_meta(seq_dir)
    cuts = [t for t in range(1, meta.frame_count) if meta.frames[t].reset]
    usable = cuts[0] if cuts else meta.frame_count
    distance = args.frames - 2 * WINDOW
    k = loop_length(usable, distance)
    box = crop_box(args.crop, meta.lr_size)

    model, record = load(args.model)
    model.eval()
    samples = calibration_samples(model, open_data(args.calib, model.scale), args.calib_frames, progress=not args.no_progress)
    art = quantize_module(npu_module(model), samples, QuantizeOptions(method=args.method, int16=args.a16), name="drift")
    if box[2:] != tuple(meta.lr_size):  # same scales and zero points, shapes traced again for the crop
        from mnss_kit.export.npu_stage import retarget
        from mnss_kit.quantize.tflite_writer import to_tflite

        graph = retarget(art.graph, npu_module(model), (box[2] * meta.scale, box[3] * meta.scale))
        art = dataclasses.replace(art, graph=graph, tflite=to_tflite(graph))
    methods = {"fp32": model_method(model), "int8": model_method(int8_model(model, art, args.runtime))}

    frames, references, backward_motion = load_source(seq_dir, k, box, meta.scale, args.inversion_steps)
    plan = schedule(k, args.frames)
    states = {name: None for name in methods}
    scores = {name: [] for name in methods}
    with torch.no_grad():
        for i, (j, backward) in enumerate(tqdm(plan, desc="drift", unit="frame", disable=args.no_progress)):
            frame = dict(frames[j], reset=torch.full((1,), 1.0 if i == 0 else 0.0))
            if backward:
                frame["motion"] = backward_motion[j]
            for name, method in methods.items():
                output, _, states[name] = method(frame, states[name])
                scores[name].append(psnr(np.clip(to_image(output), 0.0, 1.0), references[j]))

    early = (WINDOW, 2 * WINDOW - 1)
    late = (args.frames - WINDOW, args.frames - 1)
    windows = {}
    for key, (a, b) in (("early", early), ("late", late)):
        windows[key] = {"first": a, "last": b, **{f"{n}_psnr": float(np.mean(scores[n][a : b + 1])) for n in methods}}
    drift = {n: windows["late"][f"{n}_psnr"] - windows["early"][f"{n}_psnr"] for n in methods}
    return {
        "benchmark": "int8_drift",
        "checkpoint": {"name": args.model, "code_version": record.get("code_version")},
        "sequence": args.sequence,
        "data": portable_path(args.data),
        "crop_lr": list(box),
        "lr_size": [box[2], box[3]],
        "hr_size": [box[2] * meta.scale, box[3] * meta.scale],
        "frames": args.frames,
        "loop": {
            "k": k, "period": 2 * k, "first_cut": cuts[0] if cuts else None, "inversion_steps": args.inversion_steps,
            "description": (f"source frames 0..{k} forward, then {k - 1}..1 backward, repeated (period {2 * k}); reset only on the "
                            f"first frame; backward steps use the inverted motion field of the following source frame "
                            f"({args.inversion_steps} fixed-point steps), an estimate where surfaces appear or vanish."),
        },
        "quantization": {"method": args.method, "a16": args.a16, "int16_tensors": art.report["int16"],
                         "calibration_data": portable_path(args.calib), "samples": len(samples)},
        "int8_runtime": args.runtime,
        "windows": windows,
        "result": {"int8_drift_db": drift["int8"], "fp32_drift_db": drift["fp32"], "tolerance_db": TOLERANCE_DB,
                   "int8_within_tolerance": abs(drift["int8"]) <= TOLERANCE_DB},
        "source_frame": [j for j, _ in plan],
        "backward": [b for _, b in plan],
        "psnr": {n: scores[n] for n in methods},
    }


if __name__ == "__main__":
    raise SystemExit(main())
