#!/usr/bin/env python
"""The detail branch of an ntaau_lr model fitted to a capture on recorded frames, then judged on
its held-back frames by the fine-tune's own judge.

    python scripts/studies/detail_fit.py --model START.pt --finetune-out runs/finetune_x --out W

``--finetune-out`` is the output of a finished ``mnss-kit finetune`` run (its ``split/tune`` and
``split/judged`` and the model it started from); ``START.pt`` an ntaau_lr checkpoint with
``model.detail`` (e.g. the default given an empty branch by ``mnss-kit train ntaau_lr_x2 --init
ntaau_lr_x2 --set model.detail=true``).  The branch is display-only, so the history never depends
on it: the model runs once over the tuned frames (after ``--warmup`` frames of each), recording the
branch's input, the display and the reference, and the branch alone is then fitted on random crops
of them (L1, Adam 1e-3, batch 8) for ``--minutes`` on one thread.  Prints the held-back table
(``mnss-kit finetune``'s) with ``finetuned`` the fitted model and ``before`` ``--before``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

CROP = 32  # LR pixels
BATCH = 8


def record(model, tune_dir: Path, warmup: int):
    """(branch inputs (N, s*s, h, w), displays (N, 3, H, W), references) of every tuned frame after the warm-up."""
    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.frames import iter_frames
    from mnss_kit.eval.methods import model_method

    captured = {}
    c_in = model.steer.c_in
    hook = model.steer.register_forward_hook(lambda m, args, out: captured.__setitem__("x", args[0][:, c_in:].clone()))
    inputs, displays, references = [], [], []
    for seq in fmt.find_sequences(tune_dir):
        method, state = model_method(model), None
        for frame in iter_frames(seq, fmt.read_meta(seq)):
            with torch.no_grad():
                output, _, state = method(frame.inputs, state)
            if frame.index >= warmup:
                inputs.append(captured["x"][0])
                displays.append(output[0].clamp(0, 1))
                references.append(torch.from_numpy(np.ascontiguousarray(frame.reference)).permute(2, 0, 1))
    hook.remove()
    return torch.stack(inputs), torch.stack(displays), torch.stack(references)


def fit(model, inputs, displays, references, minutes: float) -> int:
    """The branch fitted to ``display + detail -> reference`` on random crops; returns the steps taken."""
    from mnss_kit.model.ntaau_lr.net import detail_luma

    branch, bound, s = model.steer.detail, model.config.detail_bound, int(model.config.scale)
    optimizer = torch.optim.Adam(branch.parameters(), lr=1e-3)
    start, steps = time.time(), 0
    while time.time() - start < minutes * 60:
        pick = torch.randint(0, len(inputs), (BATCH,))
        y, x = (int(torch.randint(0, n - CROP, (1,))) for n in inputs.shape[-2:])
        hr = (slice(s * y, s * (y + CROP)), slice(s * x, s * (x + CROP)))
        luma = detail_luma(branch(inputs[pick, :, y:y + CROP, x:x + CROP]), (s * CROP, s * CROP), bound)
        loss = ((displays[pick][:, :, hr[0], hr[1]] + luma).clamp(0, 1) - references[pick][:, :, hr[0], hr[1]]).abs().mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        steps += 1
    return steps


def main() -> None:
    from mnss_kit.dataset import format as fmt
    from mnss_kit.finetune import run as finetune
    from mnss_kit.finetune.split import plan_split
    from mnss_kit.model import checkpoint

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True, help="ntaau_lr checkpoint with model.detail")
    p.add_argument("--finetune-out", required=True, type=Path, help="a finished mnss-kit finetune output")
    p.add_argument("--capture", required=True, type=Path, help="the capture that fine-tune split")
    p.add_argument("--before", default="ntaau_lr_x2", help="the model the table compares against")
    p.add_argument("--out", required=True, type=Path, help="work directory: the fitted model.pt and the judgement")
    p.add_argument("--minutes", type=float, default=10.0)
    p.add_argument("--warmup", type=int, default=4, help="frames of each tuned sequence run before recording")
    args = p.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    model, _ = checkpoint.load(args.model)
    if not getattr(model.config, "detail", False):
        sys.exit(f"{args.model}: not an ntaau_lr model with model.detail")
    data = record(model, args.finetune_out / "split" / "tune", args.warmup)
    steps = fit(model, *data, args.minutes)
    saved = torch.load(checkpoint.resolve(args.model), map_location="cpu", weights_only=False)
    saved["state_dict"] = model.state_dict()
    args.out.mkdir(parents=True, exist_ok=True)
    torch.save(saved, args.out / "model.pt")
    seqs = fmt.find_sequences(args.capture)
    settings = finetune.RECIPE | {"burn_in": 8, "window": 4}
    splits = [plan_split(s, fmt.read_meta(s), finetune.DEFAULT_HOLD_BACK, finetune.DEFAULT_WARMUP,
                         settings["burn_in"] + settings["window"]) for s in seqs]
    judged = args.out / "split" / "judged"
    if not judged.exists():
        judged.parent.mkdir(parents=True, exist_ok=True)
        judged.symlink_to((args.finetune_out / "split" / "judged").resolve())
    summary = finetune._judge(args.before, args.out / "model.pt", args.out, splits, progress=False)
    print(f"{len(data[0])} frames recorded, {steps} steps in {args.minutes:g} min")
    print(finetune.format_judgement(summary))


if __name__ == "__main__":
    main()
