#!/usr/bin/env python
"""The detail branch of an ntaau_lr model fitted to a capture on recorded frames, with no steering
phase, then judged on its held-back frames: the screens behind ``mnss-kit finetune --detail``.

    python scripts/studies/detail_fit.py --model ntaau_lr_x2 --capture CAPTURE --split W/split --out W

``--split`` holds the capture's ``tune`` and ``judged`` parts as ``mnss-kit finetune`` splits them
(written there, by the fine-tune's own split, when missing); ``--finetune-out DIR`` takes a
fine-tune's own ``DIR/split``.  The model is given an empty branch
and the branch alone is fitted for ``--minutes`` by ``mnss_kit.finetune.detail`` (recording, crops,
loss and rate as the fine-tune's); ``--flicker F`` adds F times the change of the error between
consecutive frames to the fit (``finetune.detail.FLICKER_WEIGHT``).

``--form convs`` or ``unet`` (the model's own branch, ``model.detail_form``; ``--reads history``
its clamped-history luma, ``--reads all`` the steering's features too) is judged by the
fine-tune's judge, which prints its table.  The other forms are screens of branches the chain
cannot run, fitted the same way on the same recorded inputs and judged here on the same held-back
frames, before and after the patch:

- ``display``: the display's luma in s x s blocks instead of the history's (a second NPU call);
- ``rgb``: an RGB patch (3 s*s values per LR pixel) instead of a luma one.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def display_blocks(display: torch.Tensor, scale: int) -> torch.Tensor:
    """The display's luma in s x s blocks: (N, 3, H, W) -> (N, s*s, h, w)."""
    from mnss_kit.model.taau import rgb_to_ycocg

    return nn.functional.pixel_unshuffle(rgb_to_ycocg(display.float().clamp(0, 1))[:, :1], scale)


class ScreenBranch(nn.Module):
    """A branch form the chain cannot run (three convs): ``patch(x, display) -> (N, 3, H, W)`` added to the display."""

    def __init__(self, form: str, c_in: int, width: int, bound: float, scale: int):
        super().__init__()
        self.form, self.bound, self.scale = form, bound, scale
        out = 3 * scale * scale if form == "rgb" else 4
        c_in = scale * scale if form == "display" else c_in
        self.decode = nn.Sequential(nn.Conv2d(c_in, width, 3, padding=1), nn.ReLU(), nn.Conv2d(width, width, 3, padding=1),
                                    nn.ReLU(), nn.Conv2d(width, out, 3, padding=1))
        nn.init.zeros_(self.decode[-1].weight)  # draws nothing at the start, as the model's branch
        nn.init.zeros_(self.decode[-1].bias)

    def patch(self, x: torch.Tensor, display: torch.Tensor) -> torch.Tensor:
        from mnss_kit.model.ntaau_lr.net import detail_luma

        if self.form == "display":
            x = display_blocks(display, self.scale)
        raw = self.decode(x)
        if self.form == "rgb":
            return nn.functional.pixel_shuffle(self.bound * torch.tanh(raw), self.scale)
        return detail_luma(raw, display.shape[-2:], self.bound).expand(-1, 3, -1, -1)


def fit_screen(branch: ScreenBranch, recorded, seconds: float) -> int:
    """``branch`` fitted as ``finetune.detail.fit_branch`` fits the model's own: L1 on random crops."""
    from mnss_kit.finetune import detail

    optimizer = torch.optim.Adam(branch.parameters(), lr=detail.LR)
    crop_h = min(detail.CROP, *(t.shape[-2] for t in recorded.inputs)) // 2 * 2  # even, as the fine-tune's
    crop_w = min(detail.CROP, *(t.shape[-1] for t in recorded.inputs)) // 2 * 2
    pool = detail._fitted_entries(recorded, paired=False)
    steps, start = 0, time.monotonic()
    while time.monotonic() - start < seconds:
        x, display, reference, _, _ = detail._batch(recorded, pool, crop_h, crop_w, branch.scale)
        loss = ((display + branch.patch(x, display)).clamp(0, 1) - reference).abs().mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        steps += 1
    return steps


def judge_screen(model, branch: ScreenBranch, judged_dir: Path, warmup: int) -> tuple[float, float, int]:
    """Mean held-back PSNR over frames ``>= warmup`` of ``model`` (its branch empty) before and after
    ``branch`` draws its patch from the inputs the model's branch would read."""
    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.frames import iter_frames
    from mnss_kit.eval.methods import model_method
    from mnss_kit.metrics.psnr import psnr

    before, after = [], []
    with model.recording_detail_inputs() as branch_inputs:
        for seq in fmt.find_sequences(judged_dir):
            method, state = model_method(model), None
            for frame in iter_frames(seq, fmt.read_meta(seq)):
                with torch.no_grad():
                    output, _, state = method(frame.inputs, state)
                    h, w = output.shape[-2] // branch.scale, output.shape[-1] // branch.scale
                    x = branch_inputs[-1][:, :, :h + h % 2, :w + w % 2]
                    patch = branch.patch(x, output.clamp(0, 1))[..., :output.shape[-2], :output.shape[-1]]
                    drawn = (output + patch).clamp(0, 1)
                branch_inputs.clear()
                if frame.index >= warmup:
                    before.append(psnr(output[0].clamp(0, 1).permute(1, 2, 0).numpy(), frame.reference))
                    after.append(psnr(drawn[0].permute(1, 2, 0).numpy(), frame.reference))
    return float(np.mean(before)), float(np.mean(after)), len(before)


def main() -> None:
    from mnss_kit.dataset import format as fmt
    from mnss_kit.fileio import atomic_write_json
    from mnss_kit.finetune import detail, run as finetune
    from mnss_kit.finetune.split import plan_split, write_split
    from mnss_kit.model import checkpoint

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", default="ntaau_lr_x2", help="an ntaau_lr checkpoint or shipped name")
    p.add_argument("--capture", required=True, type=Path, help="the capture to split")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--split", type=Path, help="its tune/ and judged/ parts (written when missing)")
    where.add_argument("--finetune-out", type=Path, help="a mnss-kit finetune output of the capture: its split/")
    p.add_argument("--out", required=True, type=Path, help="work directory: the fitted model.pt and the judgement")
    p.add_argument("--minutes", type=float, default=10.0, help="fitting time (recording not included)")
    p.add_argument("--width", type=int, default=None, help="the branch's width (default: model.detail_width's)")
    p.add_argument("--bound", type=float, default=None, help="the patch's bound (default: model.detail_bound's)")
    p.add_argument("--reads", choices=("history", "all"), default="history", help="model.detail_reads")
    p.add_argument("--form", choices=("convs", "unet", "display", "rgb"), default="convs",
                   help="the branch: model.detail_form (convs, unet) or a screen (display, rgb)")
    p.add_argument("--flicker", type=float, default=0.0,
                   help="weight of the error's change between consecutive frames (finetune.detail.FLICKER_WEIGHT)")
    p.add_argument("--threads", type=int, default=1)
    args = p.parse_args()
    args.split = args.split or args.finetune_out / "split"
    torch.set_num_threads(args.threads)
    seqs = fmt.find_sequences(args.capture)
    settings = finetune.RECIPE | {"burn_in": 8, "window": 4}
    splits = [plan_split(s, fmt.read_meta(s), finetune.DEFAULT_HOLD_BACK, finetune.DEFAULT_WARMUP,
                         settings["burn_in"] + settings["window"]) for s in seqs]
    write_split(seqs, splits, args.split / "tune", args.split / "judged")

    own_form = args.form in ("convs", "unet")
    branch_settings = {"detail_reads": args.reads, "detail_form": args.form if own_form else "convs",
                       **{k: v for k, v in (("detail_width", args.width),
                                                                       ("detail_bound", args.bound)) if v is not None}}
    model, record = detail.with_empty_branch(checkpoint.resolve(args.model), branch_settings)
    recorded = detail.record_frames(model, args.split / "tune", finetune.DEFAULT_WARMUP)
    if not own_form:
        c = model.config
        branch = ScreenBranch(args.form, recorded[0][0].shape[0], c.detail_width, c.detail_bound, int(c.scale))
        steps = fit_screen(branch, recorded, args.minutes * 60)
        print(f"{len(recorded[0])} frames recorded, {steps} steps in {args.minutes:g} min")
        before, after, frames = judge_screen(model, branch, args.split / "judged", finetune.DEFAULT_WARMUP)
        print(f"{args.form} branch (reads {args.reads}) on {frames} held-back frames: "
              f"{before:.2f} -> {after:.2f} dB ({after - before:+.2f})")
        return
    with tempfile.TemporaryDirectory() as scratch:
        steps = detail.fit_branch(model, recorded, args.minutes * 60, Path(scratch) / "last.pt", record,
                                  flicker_weight=args.flicker)
    print(f"{len(recorded[0])} frames recorded, {steps} steps in {args.minutes:g} min")
    checkpoint.save(args.out / "model.pt", model, record)
    judged = args.out / "split" / "judged"
    if not judged.exists():
        judged.parent.mkdir(parents=True, exist_ok=True)
        judged.symlink_to((args.split / "judged").resolve())
    summary = finetune._judge(args.model, args.out / "model.pt", args.out, splits, progress=False)
    atomic_write_json(args.out / "heldback.json", summary)
    print(finetune.format_judgement(summary))


if __name__ == "__main__":
    main()
