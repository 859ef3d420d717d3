#!/usr/bin/env python
"""Why the ntaau family steers a display filter: one fixed 3x3 filter, fitted by least squares to
the toolkit's TAAU output against the 16-sample reference, and what it is worth per sequence.

    python scripts/display_filter_fit.py --data data/test_x2

Runs TAAU over the first FRAMES frames of each sequence, fits one 3x3 kernel (shared by the
colour channels, every sequence at once) on frames BURN_IN and later, and prints the kernel and
each sequence's PSNR before and after it.  In-sample by design: nine numbers fitted on about
ten million pixels say how far TAAU's blend is from the reference in a way a small linear filter
undoes, not how a model does on unseen data.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

FRAMES, BURN_IN, EVERY = 24, 8, 5  # frames per sequence; TAAU's history settles; pixel subsampling of the fit


def taau_frames(data: Path) -> dict[str, tuple[list[np.ndarray], list[np.ndarray]]]:
    """``{sequence: (TAAU outputs, references)}`` (H, W, 3) float64, frames BURN_IN to FRAMES - 1."""
    import torch

    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.baselines import baseline_methods
    from mnss_kit.eval.frames import iter_frames

    taau = baseline_methods(2, ("taau",))["taau"]
    out = {}
    for seq in fmt.find_sequences(data):
        state, outputs, references = None, [], []
        with torch.no_grad():
            for frame in iter_frames(seq, fmt.read_meta(seq), FRAMES):
                output, _, state = taau(frame.inputs, state)
                if frame.index >= BURN_IN:
                    outputs.append(output[0].permute(1, 2, 0).numpy().astype(np.float64))
                    references.append(frame.reference.astype(np.float64))
        out[seq.name] = (outputs, references)
    return out


def taps(image: np.ndarray) -> np.ndarray:
    """(H, W, 3) -> (H, W, 3, 9): each pixel's 3x3 neighbourhood, clamp-to-edge, row-major."""
    h, w = image.shape[:2]
    p = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="edge")
    return np.stack([p[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)], axis=-1)


def fit_kernel(pairs) -> np.ndarray:
    xs = [taps(o).reshape(-1, 9)[::EVERY] for o, _ in pairs]
    ys = [r.reshape(-1)[::EVERY] for _, r in pairs]
    kernel, *_ = np.linalg.lstsq(np.concatenate(xs), np.concatenate(ys), rcond=None)
    return kernel


def main() -> int:
    from mnss_kit.metrics.psnr import psnr

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("data/test_x2"))
    args = parser.parse_args()
    frames = taau_frames(args.data)
    kernel = fit_kernel([pair for outputs, refs in frames.values() for pair in zip(outputs, refs)])
    print("kernel (rows of the 3x3 neighbourhood):")
    for row in kernel.reshape(3, 3):
        print("  " + " ".join(f"{v:+.3f}" for v in row))
    print("| sequence | TAAU PSNR | filtered | gain |\n|---|---:|---:|---:|")
    for name, (outputs, refs) in frames.items():
        before = psnr(np.stack(outputs), np.stack(refs))
        after = psnr(np.stack([np.clip(taps(o) @ kernel, 0, 1) for o in outputs]), np.stack(refs))
        print(f"| {name} | {before:.2f} | {after:.2f} | {after - before:+.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
