#!/usr/bin/env python
"""Why the ntaau family steers a display filter: one fixed 3x3 filter, fitted by least squares to
the toolkit's TAAU output against the 16-sample reference, and what it is worth per sequence.

    python scripts/studies/display_filter_fit.py --data data/test_x2
    python scripts/studies/display_filter_fit.py --model ntaau_x2 --size 5 --apply DIR   # a model's output, 5x5

Runs TAAU (or ``--model``) over the first FRAMES frames of each sequence, fits one kernel of
``--size`` (shared by the colour channels, every sequence at once) on frames BURN_IN and later,
and prints the kernel and each sequence's PSNR before and after it.  In-sample by design on
``--data``: nine numbers fitted on about ten million pixels say how far the output is from the
reference in a way a small linear filter undoes, not how a model does on unseen data; the sets
of ``--apply`` get the same kernel out of sample.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

FRAMES, BURN_IN, EVERY = 24, 8, 5  # frames per sequence; TAAU's history settles; pixel subsampling of the fit


def method(model: str | None):
    """TAAU (``None``) or a checkpoint, as a per-frame callable ``(inputs, state) -> (output, aux, state)``."""
    if model is None:
        from mnss_kit.eval.baselines import baseline_methods

        return baseline_methods(2, ("taau",))["taau"]
    from mnss_kit.eval.methods import model_method
    from mnss_kit.model.checkpoint import load

    return model_method(load(model)[0].eval())


def output_frames(data: Path, run) -> dict[str, tuple[list[np.ndarray], list[np.ndarray]]]:
    """``{sequence: (outputs of run, references)}`` (H, W, 3) float64, frames BURN_IN to FRAMES - 1."""
    import torch

    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.frames import iter_frames

    out = {}
    for seq in fmt.find_sequences(data):
        state, outputs, references = None, [], []
        with torch.no_grad():
            for frame in iter_frames(seq, fmt.read_meta(seq), FRAMES):
                output, _, state = run(frame.inputs, state)
                if frame.index >= BURN_IN:
                    outputs.append(output[0].permute(1, 2, 0).numpy().astype(np.float64))
                    references.append(frame.reference.astype(np.float64))
        out[seq.name] = (outputs, references)
    return out


def taps(image: np.ndarray, size: int = 3) -> np.ndarray:
    """(H, W, 3) -> (H, W, 3, size^2): each pixel's size x size neighbourhood, clamp-to-edge, row-major."""
    h, w = image.shape[:2]
    r = size // 2
    p = np.pad(image, ((r, r), (r, r), (0, 0)), mode="edge")
    return np.stack([p[dy:dy + h, dx:dx + w] for dy in range(size) for dx in range(size)], axis=-1)


def fit_kernel(pairs, size: int = 3) -> np.ndarray:
    xs = [taps(o, size).reshape(-1, size * size)[::EVERY] for o, _ in pairs]
    ys = [r.reshape(-1)[::EVERY] for _, r in pairs]
    kernel, *_ = np.linalg.lstsq(np.concatenate(xs), np.concatenate(ys), rcond=None)
    return kernel


def print_gains(frames, kernel: np.ndarray, size: int, label: str) -> None:
    """One table row per sequence: the PSNR of its frames before and after the kernel."""
    from mnss_kit.metrics.psnr import psnr

    print(f"| sequence | {label} PSNR | filtered | gain |\n|---|---:|---:|---:|")
    for name, (outputs, refs) in frames.items():
        before = psnr(np.stack(outputs), np.stack(refs))
        after = psnr(np.stack([np.clip(taps(o, size) @ kernel, 0, 1) for o in outputs]), np.stack(refs))
        print(f"| {name} | {before:.2f} | {after:.2f} | {after - before:+.2f} |")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("data/test_x2"), help="the set the kernel is fitted on")
    parser.add_argument("--model", help="a checkpoint or zoo name whose output is filtered (default: TAAU's)")
    parser.add_argument("--size", type=int, default=3, choices=(3, 5), help="the kernel's width in HR pixels")
    parser.add_argument("--apply", type=Path, nargs="*", default=[], help="sets the fitted kernel is also tried on")
    args = parser.parse_args()
    run, label = method(args.model), args.model or "TAAU"
    frames = output_frames(args.data, run)
    kernel = fit_kernel([pair for outputs, refs in frames.values() for pair in zip(outputs, refs)], args.size)
    print(f"kernel (rows of the {args.size}x{args.size} neighbourhood):")
    for row in kernel.reshape(args.size, args.size):
        print("  " + " ".join(f"{v:+.3f}" for v in row))
    print_gains(frames, kernel, args.size, label)
    for data in args.apply:
        print(f"\n{data} (out of sample)")
        print_gains(output_frames(data, run), kernel, args.size, label)
    return 0


if __name__ == "__main__":
    sys.exit(main())
