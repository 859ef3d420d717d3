#!/usr/bin/env python
"""What each steering value of an ntaau or ntaau_lr model is worth, sequence by sequence: the model run with
one of its steering outputs held at TAAU's own value, against TAAU.

    python scripts/studies/steering_ablation.py --data data/test_x2 --model ntaau_x2

No retraining: the trained net runs unchanged and only the chosen raw outputs are replaced
before they are mapped (a raw 0 is TAAU's value for each: gains of 1, the clamp box as TAAU sets
it, no correction, no fallback, no display filter).  Two more rows bound the history gain instead:
at least TAAU's (``history >= taau``) or at most (``history <= taau``).  Each cell is the mean over
the first ``--frames`` (24) of the per-frame PSNR difference to TAAU, in dB; the columns are the
sequences, the last their mean.  For ntaau a second table gives the mean and standard deviation over
every HR pixel of those frames of the trained steering values, mapped to their ranges (the
history gain before the floor ``history_gain_min`` puts under it on still pixels).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from error_breakdown import model_and_data_args, sequences_in, squared_error  # noqa: E402

# raw steering channels per family: ntaau (model.taau.steer_from_raw) 0 history gain, 1 sample
# gain, 2 box, 3-5 correction, 6-7 display filter; ntaau_lr (model.ntaau_lr.net.steer_from_lr) 0
# history gain, 1 sample gain, 2 box, 3 spatial fallback, 4-5 display filter
ABLATIONS = {
    "ntaau": {"as trained": None, "history gain": (0,), "sample gain": (1,), "clamp box": (2,),
              "correction": (3, 4, 5), "display filter": (6, 7), "history >= taau": "floor",
              "history <= taau": "cap"},
    "ntaau_lr": {"as trained": None, "history gain": (0,), "sample gain": (1,), "clamp box": (2,),
                 "fallback": (3,), "display filter": (4, 5), "history >= taau": "floor",
                 "history <= taau": "cap", "filter sharpens only": "sharpen"},
}


def held(raw, change):
    """``raw`` steering with ``change`` applied (see ABLATIONS)."""
    raw = raw.clone()
    if change == "floor":
        raw[:, 0] = raw[:, 0].clamp(min=0.0)
    elif change == "cap":
        raw[:, 0] = raw[:, 0].clamp(max=0.0)
    elif change == "sharpen":  # ntaau_lr's display filter weights (4, 5) at most 0: no blur
        raw[:, 4:6] = raw[:, 4:6].clamp(max=0.0)
    elif change is not None:
        raw[:, list(change)] = 0.0
    return raw


def frame_psnrs(seq: Path, step, frames: int) -> np.ndarray:
    """Per-frame PSNR of a recurrent ``step(inputs, state) -> (output, ..., state)``."""
    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.frames import iter_frames
    from mnss_kit.metrics.psnr import mse_psnr

    meta, state, out = fmt.read_meta(seq), None, []
    for frame in iter_frames(seq, meta, frames):
        output, *_, state = step(frame.inputs, state)
        out.append(mse_psnr(float(squared_error(output, frame.reference).mean())))
    return np.array(out)


def ablated_step(model, change, seen: list | None = None):
    """The model's recurrent step with ``change`` applied (replacing the step of any earlier call
    on the same model); ``seen`` collects the raw steering."""
    import torch

    from mnss_kit.eval.methods import model_method

    steer = model.steer
    trained = type(steer).forward

    def forward(features):
        raw = held(trained(steer, features), change)
        if seen is not None:
            seen.append(raw)
        return raw

    steer.forward = forward
    run = model_method(model)

    def step(inputs, state):
        with torch.no_grad():
            return run(inputs, state)

    return step


def steering_stats(model, raw: list) -> dict[str, tuple[float, float]]:
    """Mean and standard deviation of each mapped steering value over ``raw`` (N, 8, H, W) tensors."""
    import torch

    from mnss_kit.model.taau import steer_from_raw

    c = model.config
    steer = steer_from_raw(torch.cat(raw), c.correction_bound, 0.0, c.filter_bound, c.box_bound)
    values = {"history gain": steer.history_gain, "sample gain": steer.sample_gain, "box widening": steer.box_widen}
    if isinstance(steer.filter_axis, torch.Tensor):
        values.update({"filter axis": steer.filter_axis, "filter diagonal": steer.filter_diagonal})
    return {k: (float(v.mean()), float(v.std())) for k, v in values.items()}


def main() -> int:
    from mnss_kit.dataset import format as fmt
    from mnss_kit.errors import UserError
    from mnss_kit.eval.baselines import TAAU
    from mnss_kit.model.checkpoint import load

    args = model_and_data_args(__doc__.splitlines()[0], extra=lambda p: p.add_argument(
        "--rows", nargs="+", help="only these rows, by name (e.g. 'as trained' 'display filter')"))
    try:
        sequences = sequences_in(args.data)
        model = load(args.model)[0].eval()
        family = model.config.family
        if family not in ABLATIONS:
            raise UserError(f"{args.model}: a {family} model; only ntaau and ntaau_lr models steer TAAU")
        taau = {seq.name: frame_psnrs(seq, TAAU(fmt.read_meta(seq).scale).step, args.frames) for seq in sequences}
        print("| steering | " + " | ".join(f"`{s.name}`" for s in sequences) + " | mean |")
        print("|---|" + "---:|" * (len(sequences) + 1))
        stats = {}
        rows = {k: v for k, v in ABLATIONS[family].items() if not args.rows or k in args.rows}
        for name, change in rows.items():
            margins = []
            for seq in sequences:
                seen = [] if change is None and family == "ntaau" else None
                margins.append(float((frame_psnrs(seq, ablated_step(model, change, seen), args.frames) - taau[seq.name]).mean()))
                if seen:
                    stats[seq.name] = steering_stats(model, seen)
            label = f"{name} held" if isinstance(change, tuple) else name
            print(f"| {label} | " + " | ".join(f"{m:+.3f}" for m in margins) + f" | {np.mean(margins):+.3f} |", flush=True)
        if not stats:
            return 0
        print("\n| steering value, mean (std) | " + " | ".join(f"`{s}`" for s in stats) + " |")
        print("|---|" + "---:|" * len(stats))
        for value in next(iter(stats.values())):
            print(f"| {value} | " + " | ".join(f"{st[value][0]:+.3f} ({st[value][1]:.3f})" for st in stats.values()) + " |")
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
