#!/usr/bin/env python
"""Where a model's remaining error is, against TAAU: squared error split by history length,
motion and edges.

    python scripts/studies/error_breakdown.py --data data/test_x2 --model ntaau_x2

Runs the model and the toolkit's TAAU side by side over the first FRAMES frames of each
sequence and sorts every HR pixel of every frame into a class by

- history: the weight of TAAU's reprojected history before this frame's blend (in samples
  that landed on the pixel; at most 1/alpha - 1 = 9): short (< 0.5), medium (< 4), long;
- motion: still (moved less than 0.1 HR pixels) or moving;
- edge: the reference's luma gradient, |d/dx| + |d/dy| over central differences, above 0.05.

The classes come from TAAU and the reference alone, so models of any family are split alike.
Per sequence it prints the PSNR of the pooled squared error over all frames (not the mean of
per-frame PSNRs the results tables report), then per class its share of the pixels, the
model's and TAAU's shares of their own squared error and the ratio of their mean squared
errors (below 1: the model is better there).  The last table pools every sequence.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

FRAMES = 24
HISTORY_BINS = ((0.5, "short"), (4.0, "medium"), (np.inf, "long"))
STILL_PX, EDGE_GRADIENT = 0.1, 0.05


@dataclass
class Tally:
    """Squared-error sums per class, and pixel counts."""

    model: dict[str, float] = field(default_factory=dict)
    taau: dict[str, float] = field(default_factory=dict)
    pixels: dict[str, int] = field(default_factory=dict)

    def add(self, label: str, model_se: float, taau_se: float, pixels: int) -> None:
        self.model[label] = self.model.get(label, 0.0) + model_se
        self.taau[label] = self.taau.get(label, 0.0) + taau_se
        self.pixels[label] = self.pixels.get(label, 0) + pixels

    def merge(self, other: "Tally") -> None:
        for label in other.pixels:
            self.add(label, other.model[label], other.taau[label], other.pixels[label])


def pixel_classes(history_weight: np.ndarray, motion_px: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(H, W) class labels such as ``short|moving|edge``."""
    uppers, names = zip(*HISTORY_BINS)
    history = np.array(names, dtype=object)[np.searchsorted(uppers, history_weight, side="right")]
    motion = np.where(motion_px < STILL_PX, "still", "moving").astype(object)
    gy, gx = np.gradient(reference.mean(axis=2))
    edge = np.where(np.abs(gx) + np.abs(gy) > EDGE_GRADIENT, "edge", "flat").astype(object)
    return history + "|" + motion + "|" + edge


def sequence_tally(seq: Path, model, frames: int) -> Tally:
    import torch

    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.baselines import TAAU
    from mnss_kit.eval.frames import iter_frames
    from mnss_kit.eval.methods import model_method

    meta = fmt.read_meta(seq)
    taau, run_model = TAAU(meta.scale), model_method(model)
    tally, model_state, taau_state = Tally(), None, None
    for frame in iter_frames(seq, meta, frames):
        with torch.no_grad():
            output, _, model_state = run_model(frame.inputs, model_state)
        taau_output, inputs, taau_state = taau.step(frame.inputs, taau_state)
        model_se = squared_error(output, frame.reference)
        taau_se = squared_error(taau_output, frame.reference)
        labels = pixel_classes(inputs.history_weight[0, 0].numpy(), inputs.hr_motion[0].norm(dim=0).numpy(), frame.reference)
        for label in np.unique(labels):
            sel = labels == label
            tally.add(label, float(model_se[sel].sum()), float(taau_se[sel].sum()), int(sel.sum()))
    return tally


def squared_error(output, reference: np.ndarray) -> np.ndarray:
    """(H, W) squared error over the colour channels, the output clamped to [0, 1] as eval does."""
    from mnss_kit.metrics.image import to_image

    image = np.clip(to_image(output), 0.0, 1.0).astype(np.float64)
    return ((image - reference) ** 2).mean(axis=2)


def print_table(name: str, tally: Tally) -> None:
    pixels, model_total, taau_total = (sum(d.values()) for d in (tally.pixels, tally.model, tally.taau))
    psnr = lambda se: 10.0 * np.log10(pixels / se)  # noqa: E731
    print(f"\n{name}: model {psnr(model_total):.2f} dB, TAAU {psnr(taau_total):.2f} dB (pooled squared error)\n")
    print("| history / motion / edge | pixels | model's error | TAAU's error | model MSE / TAAU MSE |")
    print("|---|---:|---:|---:|---:|")
    for label in sorted(tally.pixels, key=lambda k: -tally.model[k]):
        ratio = tally.model[label] / tally.taau[label] if tally.taau[label] > 0 else float("nan")
        print(f"| {label.replace('|', ' / ')} | {tally.pixels[label] / pixels:.1%} | {tally.model[label] / model_total:.1%} "
              f"| {tally.taau[label] / taau_total:.1%} | {ratio:.2f} |")


def model_and_data_args(description: str, extra=None) -> argparse.Namespace:
    """``--data``, ``--model`` and ``--frames``, the arguments of the scripts that set a model against
    TAAU, and what ``extra(parser)`` adds."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--data", type=Path, default=Path("data/test_x2"), help="a dataset or sequence directory")
    parser.add_argument("--model", default="ntaau_x2", help="a checkpoint or a shipped name")
    parser.add_argument("--frames", type=int, default=FRAMES, help="frames per sequence, from the first")
    if extra is not None:
        extra(parser)
    return parser.parse_args()


def sequences_in(data: Path) -> list[Path]:
    from mnss_kit.dataset import format as fmt
    from mnss_kit.errors import UserError

    sequences = fmt.find_sequences(data)
    if not sequences:
        raise UserError(f"{data}: no sequences found")
    return sequences


def exit_status(body) -> int:
    """Run ``body()``: 0, or a user mistake (UserError) as one line on stderr and 2."""
    from mnss_kit.errors import UserError

    try:
        body()
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


def main() -> int:
    from mnss_kit.model.checkpoint import load

    args = model_and_data_args(__doc__.splitlines()[0])

    def body():
        model, _ = load(args.model)
        model.eval()
        sequences = sequences_in(args.data)
        pooled = Tally()
        for seq in sequences:
            tally = sequence_tally(seq, model, args.frames)
            print_table(seq.name, tally)
            pooled.merge(tally)
        print_table(f"all {len(sequences)} sequences", pooled)

    return exit_status(body)


if __name__ == "__main__":
    sys.exit(main())
