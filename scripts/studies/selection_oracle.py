#!/usr/bin/env python
"""How much a per-region choice between a model and the baselines could add: an oracle bound.

    python scripts/studies/selection_oracle.py --data OUT/split/judged --model ntaau_lr_x2

Runs the model, TAAU, the FSR2-class upscaler and bicubic side by side over each sequence and,
on every frame after the warm-up, lets an oracle that sees the reference pick, in each block of
BLOCK x BLOCK HR pixels, the output with the least squared error (the model or one baseline, and
the model or any of them), or blend the model with one baseline by the weight in [0, 1] that
fits the reference best.  A net that chooses or blends these outputs per region, from what the
GPU gives it, can do no better than this oracle at its block size.  So when the oracle over the
model and a baseline gains little, a selector between them is not the design to try; when it
gains much, what the oracle picks (and where) says what a selector would have to see.

Prints the mean of per-frame PSNRs (as the results tables and ``finetune``'s held-back table do)
for each method, each oracle's gain over the model, and for each baseline the share of blocks
where it beats the model.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from error_breakdown import exit_status, model_and_data_args, sequences_in  # noqa: E402

BASELINES = ("taau", "fsr2", "bicubic")
BLOCKS = (4, 8, 16)  # HR pixels per block side: 2, 4 and 8 LR pixels at x2
WARMUP = 4  # frames of each sequence run but not counted, as the fine-tune's judge does


def block_sums(values: np.ndarray, block: int) -> np.ndarray:
    """(H, W, ...) -> per-block sums (H // block, W // block) over the block and any trailing axes;
    an edge remainder is dropped."""
    h, w = (values.shape[0] // block) * block, (values.shape[1] // block) * block
    return values[:h, :w].reshape(h // block, block, w // block, block, -1).sum(axis=(1, 3, 4))


def blended_error(model: np.ndarray, base: np.ndarray, reference: np.ndarray, block: int) -> np.ndarray:
    """Per-block squared error (channel mean per pixel, as ``squared_error``) of ``base + a (model - base)``
    with each block's least-squares ``a`` clipped to [0, 1]."""
    d, e = model - base, reference - base
    dd, de, ee = (block_sums(x, block) for x in (d * d, d * e, e * e))
    a = np.clip(de / np.maximum(dd, 1e-12), 0.0, 1.0)
    return (ee - 2.0 * a * de + a * a * dd) / reference.shape[2]


def frame_psnr(se_sum: float, pixels: int) -> float:
    return float(10.0 * np.log10(pixels / max(se_sum, 1e-12)))


def sequence_rows(seq: Path, model, frames: int | None, warmup: int) -> list[dict]:
    """One dict per counted frame: PSNR per method and per oracle, and the blocks each baseline wins."""
    import torch

    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.baselines import baseline_methods
    from mnss_kit.eval.frames import iter_frames
    from mnss_kit.eval.methods import model_method
    from mnss_kit.metrics.image import to_image

    meta = fmt.read_meta(seq)
    methods = {"model": model_method(model), **baseline_methods(meta.scale, BASELINES)}
    states = dict.fromkeys(methods)
    rows = []
    for t, frame in enumerate(iter_frames(seq, meta, frames)):
        images = {}
        for name, method in methods.items():
            with torch.no_grad():
                output, _, states[name] = method(frame.inputs, states[name])
            images[name] = np.clip(to_image(output), 0.0, 1.0).astype(np.float64)
        if t < warmup:
            continue
        reference = frame.reference.astype(np.float64)
        errors = {name: ((image - reference) ** 2).mean(axis=2) for name, image in images.items()}
        row = {name: frame_psnr(se.sum(), se.size) for name, se in errors.items()}
        for block in BLOCKS:
            sums = {name: block_sums(se, block) for name, se in errors.items()}
            pixels = sums["model"].size * block * block
            row[f"model@{block}"] = frame_psnr(sums["model"].sum(), pixels)  # on the blocks' area, for the gains
            for base in BASELINES:
                row[f"model|{base}@{block}"] = frame_psnr(np.minimum(sums["model"], sums[base]).sum(), pixels)
                blended = blended_error(images["model"], images[base], reference, block)
                row[f"model+{base}@{block}"] = frame_psnr(blended.sum(), pixels)
                row[f"{base} wins@{block}"] = float((sums[base] < sums["model"]).mean())
            row[f"any@{block}"] = frame_psnr(np.min(np.stack(list(sums.values())), axis=0).sum(), pixels)
        rows.append(row)
    return rows


def print_table(rows: list[dict]) -> None:
    mean = lambda key: float(np.mean([r[key] for r in rows]))  # noqa: E731
    base = mean("model")
    print(f"\n{len(rows)} frames; the model {base:.2f} dB, "
          + ", ".join(f"{b} {mean(b):.2f}" for b in BASELINES) + "; gains over the model:\n")
    print("| block (HR px) | " + " | ".join(f"model or {b}" for b in BASELINES) + " | model or any | "
          + " | ".join(f"model blended with {b}" for b in BASELINES) + " | "
          + " | ".join(f"blocks {b} wins" for b in BASELINES) + " |")
    print("|---:|" + "---:|" * (3 * len(BASELINES) + 1))
    for block in BLOCKS:
        start = mean(f"model@{block}")  # the model on the whole blocks only: an edge remainder is left out
        picks = [f"{mean(f'model|{b}@{block}') - start:+.2f}" for b in BASELINES]
        blends = [f"{mean(f'model+{b}@{block}') - start:+.2f}" for b in BASELINES]
        wins = [f"{mean(f'{b} wins@{block}'):.0%}" for b in BASELINES]
        print(f"| {block} | " + " | ".join(picks) + f" | {mean(f'any@{block}') - start:+.2f} | " + " | ".join(blends)
              + " | " + " | ".join(wins) + " |")


def main() -> int:
    from mnss_kit.errors import UserError
    from mnss_kit.model.checkpoint import load

    args = model_and_data_args(__doc__.splitlines()[0], lambda p: p.add_argument(
        "--warmup", type=int, default=WARMUP, help="frames of each sequence run but not counted"))

    def body():
        model, _ = load(args.model)
        model.eval()
        rows = [row for seq in sequences_in(args.data) for row in sequence_rows(seq, model, args.frames, args.warmup)]
        if not rows:
            raise UserError(f"{args.data}: no frame after the {args.warmup}-frame warm-up")
        print_table(rows)

    return exit_status(body)


if __name__ == "__main__":
    sys.exit(main())
