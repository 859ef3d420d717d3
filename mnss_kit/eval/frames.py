"""Full frames of a sequence, in order, for evaluation.

The single place where evaluation reads data.  Frames come from the dataset
loader's evaluation iterator (``mnss_kit.dataset.loader.eval_sequences``:
canonical conventions, NaN checks, every optional G-buffer the sequence has),
and are split here into the model inputs and the numpy buffers the metrics
need.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np
import torch

from ..dataset import format as fmt
from ..dataset.loader import eval_sequences
from ..errors import UserError
from ..ops.scale import upsample_motion_to, upsample_nearest_to
from ..ops.warp import upsample_motion


@dataclass
class EvalFrame:
    index: int
    reset: bool
    inputs: dict[str, torch.Tensor]  # model inputs (loader keys, batch of one), no reference
    reference: np.ndarray  # (H, W, 3) display values
    hr_depth: np.ndarray  # (H, W, 1) canonical depth (HR buffer, else LR repeated)
    hr_motion: np.ndarray  # (H, W, 2) HR pixels (HR buffer, else upsampled LR motion)


def frame_count(meta: fmt.SequenceMeta, max_frames: int | None) -> int:
    return meta.frame_count if max_frames is None else min(meta.frame_count, max_frames)


def check_reference(seq_dir: Path, meta: fmt.SequenceMeta, reference: str) -> None:
    """A UserError unless the sequence has the HR buffer of reference ``reference`` (box, taa, 4x)."""
    if reference not in fmt.REFERENCE_BUFFERS:
        raise UserError(f"unknown reference '{reference}' (one of {', '.join(fmt.REFERENCE_BUFFERS)})")
    buffer = fmt.REFERENCE_BUFFERS[reference]
    if buffer not in meta.buffers.get("hr", []):
        raise UserError(f"{seq_dir}: no hr/{buffer} for --reference {reference} (render the data with "
                        f"extra_references: [{reference}]; docs/dataset.md)")


def iter_frames(seq_dir: Path, meta: fmt.SequenceMeta, max_frames: int | None = None, reference: str = "box") -> Iterator[EvalFrame]:
    """Frames ``0 .. n-1`` of one sequence with all its buffers; the first one always has reset set.

    ``reference`` (``fmt.REFERENCE_BUFFERS``: box, taa, 4x) picks the HR buffer the frame's
    ``reference`` holds; the references are never among the model inputs.
    """
    check_reference(seq_dir, meta, reference)
    references = set(fmt.REFERENCE_BUFFERS.values())
    hr_extra = [b for b in meta.buffers.get("hr", []) if b not in fmt.REQUIRED_BUFFERS["hr"] and b not in references]
    lr_extra = [b for b in meta.buffers.get("lr", []) if b not in fmt.REQUIRED_BUFFERS["lr"]]
    (sequence,) = eval_sequences(seq_dir, hr_buffers=hr_extra, lr_buffers=lr_extra, progress=False,
                                 reference=fmt.REFERENCE_BUFFERS[reference])
    s = meta.scale
    for t, frame in zip(range(frame_count(meta, max_frames)), sequence):
        inputs = {k: v for k, v in frame.items() if k != "reference"}
        if "hr_depth" in inputs:
            hr_depth = _image(inputs["hr_depth"])
        elif isinstance(s, int):  # nearest, so object edges keep one depth or the other
            hr_depth = np.repeat(np.repeat(_image(inputs["depth"]), s, axis=0), s, axis=1)
        else:  # a fractional scale: nearest at the exact per-axis ratio
            hr_depth = upsample_nearest_to(_image(inputs["depth"]), s, meta.hr_size)
        if "hr_motion" in inputs:
            hr_motion = _image(inputs["hr_motion"])
        elif isinstance(s, int):
            hr_motion = upsample_motion(_image(inputs["motion"]), s)
        else:
            hr_motion = upsample_motion_to(_image(inputs["motion"]), s, meta.hr_size)
        reset = bool(inputs["reset"][0] > 0.5)
        yield EvalFrame(t, reset, inputs, _image(frame["reference"]), hr_depth, hr_motion)


def _image(tensor: torch.Tensor) -> np.ndarray:
    """``(1, C, H, W)`` -> ``(H, W, C)`` float32."""
    return np.ascontiguousarray(tensor[0].permute(1, 2, 0).numpy(), dtype=np.float32)
