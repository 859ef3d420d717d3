#!/usr/bin/env python
"""The detail branch of an ntaau_lr model fitted to a capture on recorded frames, with no steering
phase, then judged on its held-back frames: the screens behind ``mnss-kit finetune --detail``.

    python scripts/studies/detail_fit.py --model ntaau_lr_x2 --finetune-out runs/finetune_x --capture CAPTURE --out W

``--finetune-out`` is a finished ``mnss-kit finetune`` run of ``CAPTURE`` (its ``split/tune`` and
``split/judged``).  The model is given an empty branch and the branch alone is fitted for
``--minutes`` by ``mnss_kit.finetune.detail`` (recording, crops, loss and rate as the fine-tune's).
``--input history`` (the branch's own input, the clamped history's luma) is judged by the
fine-tune's judge and prints its table; ``--input display`` (the display's luma in the same s x s
blocks, a form the model cannot run: the branch would follow the blend, a second NPU call) is
judged here on the same held-back frames.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def display_blocks(display: torch.Tensor, scale: int) -> torch.Tensor:
    """The display's luma in s x s blocks: (N, 3, H, W) -> (N, s*s, h, w)."""
    from mnss_kit.model.taau import rgb_to_ycocg

    return torch.nn.functional.pixel_unshuffle(rgb_to_ycocg(display.float().clamp(0, 1))[:, :1], scale)


def judge_display_input(plain, branch, bound: float, judged_dir: Path, warmup: int) -> tuple[float, float, int]:
    """Mean held-back PSNR over frames ``>= warmup`` of the ``plain`` model (no branch) before and after
    ``branch`` reads its display."""
    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.frames import iter_frames
    from mnss_kit.eval.methods import model_method
    from mnss_kit.metrics.psnr import psnr
    from mnss_kit.model.ntaau_lr.net import detail_luma

    before, after, s = [], [], int(plain.scale)
    for seq in fmt.find_sequences(judged_dir):
        method, state = model_method(plain), None
        for frame in iter_frames(seq, fmt.read_meta(seq)):
            with torch.no_grad():
                output, _, state = method(frame.inputs, state)
                drawn = (output + detail_luma(branch(display_blocks(output, s)), output.shape[-2:], bound)).clamp(0, 1)
            if frame.index >= warmup:
                before.append(psnr(output[0].clamp(0, 1).permute(1, 2, 0).numpy(), frame.reference))
                after.append(psnr(drawn[0].permute(1, 2, 0).numpy(), frame.reference))
    return float(np.mean(before)), float(np.mean(after)), len(before)


def main() -> None:
    from mnss_kit.dataset import format as fmt
    from mnss_kit.finetune import detail, run as finetune
    from mnss_kit.finetune.split import plan_split
    from mnss_kit.model import checkpoint

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", default="ntaau_lr_x2", help="an ntaau_lr checkpoint or shipped name")
    p.add_argument("--finetune-out", required=True, type=Path, help="a finished mnss-kit finetune output")
    p.add_argument("--capture", required=True, type=Path, help="the capture that fine-tune split")
    p.add_argument("--out", required=True, type=Path, help="work directory: the fitted model.pt and the judgement")
    p.add_argument("--minutes", type=float, default=10.0, help="fitting time (recording not included)")
    p.add_argument("--width", type=int, default=None, help="the branch's width (default: model.detail_width's)")
    p.add_argument("--bound", type=float, default=None, help="the patch's bound (default: model.detail_bound's)")
    p.add_argument("--input", choices=("history", "display"), default="history", help="what the branch reads")
    args = p.parse_args()
    torch.set_num_threads(1)
    settings = {k: v for k, v in (("detail_width", args.width), ("detail_bound", args.bound)) if v is not None}
    model, record = detail.with_empty_branch(checkpoint.resolve(args.model), settings)
    recorded = detail.record_frames(model, args.finetune_out / "split" / "tune", finetune.DEFAULT_WARMUP)
    if args.input == "display":
        recorded = ([display_blocks(d[None], int(model.scale))[0].half() for d in recorded[1]], *recorded[1:])
    with tempfile.TemporaryDirectory() as scratch:
        steps = detail.fit_branch(model, recorded, args.minutes * 60, Path(scratch) / "last.pt", record)
    print(f"{len(recorded[0])} frames recorded, {steps} steps in {args.minutes:g} min")
    checkpoint.save(args.out / "model.pt", model, record)
    if args.input == "display":  # the model's own forward would feed the branch the history: judged beside it
        plain, _ = checkpoint.load(args.model)
        before, after, frames = judge_display_input(plain, model.steer.detail, model.config.detail_bound,
                                                    args.finetune_out / "split" / "judged", finetune.DEFAULT_WARMUP)
        print(f"display-luma branch on {frames} held-back frames: {before:.2f} -> {after:.2f} dB ({after - before:+.2f})")
        return
    seqs = fmt.find_sequences(args.capture)
    settings = finetune.RECIPE | {"burn_in": 8, "window": 4}
    splits = [plan_split(s, fmt.read_meta(s), finetune.DEFAULT_HOLD_BACK, finetune.DEFAULT_WARMUP,
                         settings["burn_in"] + settings["window"]) for s in seqs]
    judged = args.out / "split" / "judged"
    if not judged.exists():
        judged.parent.mkdir(parents=True, exist_ok=True)
        judged.symlink_to((args.finetune_out / "split" / "judged").resolve())
    summary = finetune._judge(args.model, args.out / "model.pt", args.out, splits, progress=False)
    print(finetune.format_judgement(summary))


if __name__ == "__main__":
    main()
