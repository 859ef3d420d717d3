"""Running a model over recurrent windows: truncated BPTT, ground-truth history, validation.

A batch is a dict of ``(N, T, ...)`` tensors (``docs/architecture.md``).  The
model sees one frame at a time and carries its state (``history`` (N, 3, H, W)
the previous output, ``depth`` and ``jitter`` of the previous LR frame).

Ground-truth history (the pre-training trick of MNSS): during the first
epochs the state's ``history`` before frame ``t`` is replaced by the HR
reference of frame ``t - 1``, so the blending nets learn from a clean
history before they have to cope with their own mistakes.

Crop validity: a training window is a crop, and the warp fetches history
from outside the crop as clamped edge texels, which a full frame would not
do.  With a few pixels of motion per frame most of a small crop loses its
history within a few frames, and a model trained on that learns to distrust
history it could use.  ``crop_validity`` tracks, per HR pixel, whether its
history came from inside the crop ever since the last reset; the loss
ignores the other pixels (their output is swapped for the reference before
the loss, so they carry neither error nor gradient).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from ..metrics.image import psnr_torch
from ..model.layers import upsample_motion, warp_bilinear
from ..model.families import family_of


def frame_at(batch: dict[str, torch.Tensor], t: int) -> dict[str, torch.Tensor]:
    """The model inputs of time step ``t``: every key but ``reference``, time axis dropped."""
    return {k: v[:, t] for k, v in batch.items() if k != "reference"}


def detach_state(state):
    """Cut the graph at the state (truncated backpropagation through time)."""
    if isinstance(state, dict):
        return {k: detach_state(v) for k, v in state.items()}
    if isinstance(state, (list, tuple)):
        return type(state)(detach_state(v) for v in state)
    return state.detach() if isinstance(state, torch.Tensor) else state


def batch_scale(batch: dict[str, torch.Tensor], model: nn.Module):
    """The scale of a batch (or frame): its ``scale`` key (one value for the whole batch; an int
    when integral), else the model's own.  The key is float32, so the value is rounded to the 3
    decimals a scale has (``ops.scale.parse_scale``): 1.7, not 1.70000005."""
    value = batch.get("scale")
    if value is None:
        return model.scale
    first = round(float(value.reshape(-1)[0]), 3)
    if not bool((value == value.reshape(-1)[0]).all()):
        raise ValueError(f"a batch holds several scales {sorted(set(value.reshape(-1).tolist()))}; one scale per batch")
    return int(first) if first.is_integer() else first


def crop_validity(valid: torch.Tensor | None, frame: dict[str, torch.Tensor], scale, hr_size: tuple[int, int] | None = None) -> torch.Tensor:
    """Update the (N, 1, H, W) bool mask of HR pixels whose history never left the crop.

    ``valid`` is the previous frame's mask (None before the first frame).  A
    pixel stays valid when every texel its bilinear warp reads is valid and not
    on the crop's outermost ring (where clamped off-crop reads land); a reset
    frame makes every pixel valid, since it ignores its history.  ``hr_size``
    ``(H, W)`` (the reference's) is needed at a fractional scale.
    """
    color = frame["color"]
    n, _, h, w = color.shape
    integral = float(scale).is_integer()
    if hr_size is None:
        if not integral:
            raise ValueError(f"crop_validity at the fractional scale {scale} needs hr_size")
        hr_size = (h * int(scale), w * int(scale))
    if valid is None:
        valid = torch.ones(n, 1, *hr_size, dtype=torch.bool, device=color.device)
    else:
        inner = F.pad(valid[:, :, 1:-1, 1:-1], (1, 1, 1, 1)).to(color.dtype)
        if integral:
            motion = upsample_motion(frame["motion"], int(scale))
        else:  # bilinear to the HR size, in HR pixels by each axis's exact ratio
            motion = F.interpolate(frame["motion"], size=tuple(hr_size), mode="bilinear", align_corners=False)
            motion = motion * torch.tensor([hr_size[1] / w, hr_size[0] / h], dtype=motion.dtype,
                                           device=motion.device).view(1, 2, 1, 1)
        valid = warp_bilinear(inner, motion) > 0.999
    reset = frame.get("reset")
    if reset is not None:
        valid = valid | (reset > 0.5).view(n, 1, 1, 1)
    return valid


class WindowChunk(nn.Module):
    """Model plus loss over frames ``t0 .. t1 - 1`` of a window: the unit that DDP wraps.

    ``forward`` returns the chunk's loss (summed frame losses / ``loss_frames``,
    so the chunks of a window add up to the mean frame loss), its terms as a
    detached tensor in ``loss.terms`` order (same normalisation), and the
    state and crop-validity mask (or None when not masking) after frame ``t1 - 1``.
    """

    def __init__(self, model: nn.Module, loss: nn.Module):
        super().__init__()
        self.model = model
        self.loss = loss

    def forward(self, batch: dict[str, torch.Tensor], t0: int, t1: int, state: dict, valid: torch.Tensor | None,
                gt_history: bool, loss_frames: int, mask_crop: bool = True):
        total = batch["reference"].new_zeros(())
        terms = batch["reference"].new_zeros(len(self.loss.terms))
        scale = batch_scale(batch, self.model)  # the batch's scale (frame key ``scale``), else the model's
        hr_size = tuple(batch["reference"].shape[-2:])
        prev_error = None  # the flicker term pairs consecutive frames of this chunk
        for t in range(t0, t1):
            frame, state = _next_input(self.model, batch, t, state, gt_history)
            output, aux, state = self.model(frame, state)
            reference = batch["reference"][:, t]
            if mask_crop:
                valid = crop_validity(valid, frame, scale, hr_size)
                output = torch.where(valid, output, reference)
            error = output - reference
            flicker = None
            if prev_error is not None and self.loss.flicker_weight > 0:
                flicker = self.loss.flicker(error, prev_error, frame["motion"], frame.get("reset"))
            prev_error = error
            parts = self.loss(output, aux, frame, reference, valid if mask_crop else None, flicker)
            total = total + parts["total"]
            terms = terms + torch.stack([parts[k].detach() for k in self.loss.terms])
        return total / loss_frames, terms / loss_frames, state, valid


@torch.no_grad()
def burn_in(model: nn.Module, batch: dict[str, torch.Tensor], frames: int, gt_history: bool, mask_crop: bool = True):
    """Run the first ``frames`` frames of a window without gradient or loss; returns ``(state, valid)`` after them.

    Windows start without history; burning in a few frames lets the frames that
    carry the loss see an accumulated history, as every frame after the first
    few does at inference.
    """
    state = model.initial_state(frame_at(batch, 0))
    valid = None
    for t in range(frames):
        frame, state = _next_input(model, batch, t, state, gt_history)
        _, _, state = model(frame, state)
        if mask_crop:
            valid = crop_validity(valid, frame, batch_scale(batch, model), tuple(batch["reference"].shape[-2:]))
    return state, valid


def _next_input(model: nn.Module, batch: dict[str, torch.Tensor], t: int, state: dict, gt_history: bool) -> tuple[dict, dict]:
    """Frame ``t`` and the state it starts from (the reference of frame ``t - 1`` as the family's
    ``history_state`` when ``gt_history``)."""
    key = family_of(model).history_state
    if gt_history and t > 0 and key is not None:
        state = {**state, key: batch["reference"][:, t - 1]}
    return frame_at(batch, t), state


@torch.no_grad()
def validate(model: nn.Module, windows, indices: list[int], skip: int = 0) -> tuple[dict[str, float], dict[str, torch.Tensor]]:
    """Mean PSNR (dB) over the frames after the first ``skip`` of the given windows, the model running on its own history.

    Also reports the PSNR of the family's ``floor_output`` (for MNSS ``I_U``, the jittered
    upsample of the LR frame, no history), the floor the model must beat.  Returns scalars and,
    for the last frame of the first window, the output, reference and floor images (3, H, W).
    """
    floor = family_of(model).floor_output
    was_training = model.training
    model.eval()
    psnr_out, psnr_up, images = [], [], {}
    for i in indices:
        batch = {k: v.unsqueeze(0) for k, v in windows[i].items()}
        state = None
        for t in range(batch["reference"].shape[1]):
            output, aux, state = model(frame_at(batch, t), state)
            reference = batch["reference"][:, t]
            if t < skip:
                continue
            psnr_out.append(psnr_torch(output, reference))
            if floor is not None:
                psnr_up.append(psnr_torch(aux[floor].clamp(0.0, 1.0), reference))
        if not images:
            images = {"val/output": output[0], "val/reference": reference[0]}
            if floor is not None:
                images[f"val/{floor}"] = aux[floor][0]
    model.train(was_training)
    scalars = {"val/psnr": float(torch.cat(psnr_out).mean())}
    if floor is not None:
        scalars[f"val/psnr_{floor}"] = float(torch.cat(psnr_up).mean())
    return scalars, images
