"""The fine-tune's second phase (``mnss-kit finetune --detail``): a detail branch fitted to the capture.

An ntaau_lr model's detail branch (``model.detail``: a small net at LR drawing a luma patch per LR
pixel) is display-only: the history never depends on it, so it is fitted by plain regression on
frames recorded once rather than through the recurrent loop, whose steps spend their time on
burn-in frames and the steering.  The tuned model, given an empty branch (it draws nothing), runs
once over the tuned frames; after each sequence's warm-up the branch's input, the display and the
reference are kept, and the branch alone is fitted on random crops of them (L1) until its budget
ends.  With a flicker weight the crops come in pairs of consecutive frames and the change of the
error between them (``model.losses.flicker_term``) is added, since single frames cannot show the
fit a patch that is drawn anew each frame.  docs/studies/ntaau_lr.md ("A detail branch") has the
screens behind it.

    OUT/detail/last.pt   the fit so far: a rerun resumes it
    OUT/detail/model.pt  the fitted model
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch

from ..errors import UserError
from ..model import checkpoint
from ..model.config import model_config_from_dict
from ..model.families import build_model

log = logging.getLogger(__name__)

CROP = 32  # LR pixels a side
BATCH = 8
LR = 1.0e-3  # the branch starts from zero and has one capture to learn: a base run's rate, not a fine-tune's
SAVE_EVERY_S = 60.0  # an interrupted fit loses at most this much
RECORD_BYTES = 2 << 30  # recorded frames beyond this are thinned evenly (float16)
FLICKER_WEIGHT = 0.0  # of the error's change between consecutive frames, beside L1
# the branch a fine-tune fits (docs/studies/ntaau_lr.md, "A detail branch" and "What the branch reads"):
# on a factory capture a bound of 0.3 gained 0.05 dB more than 0.1; reading this frame's features
# beside the history's luma +0.24 dB more (the NPU input is the same); an encoder-decoder instead of
# three convs +0.17 more; with both, width 16 +0.30 over 8 (reading the history alone it bought +0.04)
# and width 24 +0.11 over 16: the fine-tune's +1.0 dB over the default on both captures needs 24
BRANCH = {"detail_width": 24, "detail_bound": 0.3, "detail_reads": "all", "detail_form": "unet"}


def check_detail(record: dict, model: str, what: str = "--detail") -> None:
    """One line, led by ``what``, when ``model`` (its checkpoint ``record``'s family and scale) cannot
    take a detail branch."""
    if record.get("family") != "ntaau_lr":
        raise UserError(f"{what}: {model} is a {record.get('family')} model; only ntaau_lr models take a detail branch")
    if not float(record.get("scale")).is_integer():
        raise UserError(f"{what}: {model} is x{record.get('scale')}; the detail branch takes integer scales only")


def branch_settings(width: int | None = None) -> dict:
    """The model settings of the branch a fine-tune fits: :data:`BRANCH`, of ``width`` when given."""
    return {**BRANCH, **({} if width is None else {"detail_width": width})}


def branch_config(config: dict, settings: dict | None = None, source: str = "model config"):
    """The model config ``config`` (a dict) with a detail branch, of ``settings`` (``detail_width``,
    ``detail_bound``) where given, else the config's own."""
    return model_config_from_dict({**config, "detail": True, **(settings or {})}, source=source)


def with_empty_branch(path: Path, settings: dict | None = None) -> tuple[torch.nn.Module, dict]:
    """``(model, record)``: the checkpoint at ``path`` plus a detail branch that draws nothing (the
    branch's own initial weights, last conv zero), so the model starts as the checkpoint;
    ``settings`` model settings of the branch (``detail_width``, ``detail_bound``) other than the defaults."""
    from ..train.init import initial_weights

    record, _ = checkpoint.read_record(path)
    config = branch_config(record["config"], settings, source=f"{path} record")
    torch.manual_seed(0)
    model = build_model(config)
    weights, _ = initial_weights(config, str(path))
    model.load_state_dict(weights)
    return model.eval(), record


class Recorded(NamedTuple):
    """The frames a branch is fitted on, float16, one entry per recorded frame."""

    inputs: list[torch.Tensor]  # (branch channels, h, w): what the branch reads
    displays: list[torch.Tensor]  # (3, H, W): the tuned model's display, before the patch
    references: list[torch.Tensor]  # (3, H, W)
    motions: list[torch.Tensor]  # (2, h, w): the capture's LR motion to the frame before
    previous: list[int]  # the entry of the frame before, -1 when it is not recorded or the camera cut


def record_frames(model, tune_dir: Path | list[Path], warmup: int, progress: bool = True) -> Recorded:
    """Every frame of ``tune_dir`` (sequences or directories of them) from index ``warmup`` on,
    thinned evenly to :data:`RECORD_BYTES`."""
    from tqdm import tqdm

    from ..dataset import format as fmt
    from ..eval.frames import iter_frames
    from ..eval.methods import model_method

    seqs = fmt.find_sequences(tune_dir)
    metas = [fmt.read_meta(s) for s in seqs]
    kept = _kept_indices([(s.name, len(m.frames)) for s, m in zip(seqs, metas)], warmup,
                          max(m.lr_size[0] * m.lr_size[1] for m in metas), int(model.scale),
                          model.detail_input_channels())
    recorded = Recorded([], [], [], [], [])
    bar = tqdm(total=sum(len(m.frames) for m in metas), unit="frame", desc="record", disable=None if progress else True)
    with model.recording_detail_inputs() as branch_inputs, bar:
        for seq, meta in zip(seqs, metas):
            method, state, last_kept = model_method(model), None, None
            for frame in iter_frames(seq, meta):
                with torch.no_grad():
                    output, _, state = method(frame.inputs, state)
                if (seq.name, frame.index) in kept:
                    _record(recorded, model, frame, output, branch_inputs[-1], last_kept)
                    last_kept = (frame.index, len(recorded.inputs) - 1)
                branch_inputs.clear()
                bar.update(1)
    if not recorded.inputs:
        raise UserError(f"--detail: no tuned frame after the {warmup}-frame warm-up to fit the branch on")
    return recorded


def _record(recorded: Recorded, model, frame, output: torch.Tensor, branch_input: torch.Tensor,
            last_kept: tuple[int, int] | None) -> None:
    """One frame appended to ``recorded``; ``last_kept``: (frame index, entry) of its sequence's last recorded frame."""
    h, w = output.shape[-2] // int(model.scale), output.shape[-1] // int(model.scale)
    recorded.inputs.append(branch_input[0, :, :h, :w].half())
    recorded.displays.append(output[0].clamp(0, 1).half())
    recorded.references.append(torch.from_numpy(np.ascontiguousarray(frame.reference)).permute(2, 0, 1).half())
    recorded.motions.append(frame.inputs["motion"][0, :, :h, :w].half())
    cut = "reset" in frame.inputs and float(frame.inputs["reset"].flatten()[0]) > 0.5
    follows = last_kept is not None and last_kept[0] == frame.index - 1 and not cut
    recorded.previous.append(last_kept[1] if follows else -1)


def _kept_indices(counts: list[tuple[str, int]], warmup: int, lr_pixels: int, s: int,
                  branch_channels: int) -> set[tuple[str, int]]:
    """The recorded frames of sequences ``(name, frames)``: all after each warm-up, or every k-th of
    them when they would not fit in :data:`RECORD_BYTES` (``branch_channels`` at LR, 6 at HR)."""
    after = [(name, i) for name, n in counts for i in range(warmup, n)]
    if not after:
        return set()
    per_frame = 2 * (branch_channels + 6 * s * s) * lr_pixels  # float16: the branch input, the display and the reference
    k = max(1, -(-len(after) * per_frame // RECORD_BYTES))
    if k > 1:
        log.info("--detail: %d tuned frames would not fit in %d MiB; fitting on every %d-th", len(after), RECORD_BYTES >> 20, k)
    return set(after[::k])


def fit_branch(model, recorded: Recorded, seconds: float, last: Path, record: dict, progress: bool = True,
               flicker_weight: float = FLICKER_WEIGHT) -> int:
    """The branch fitted to ``display + patch -> reference`` on random crops for ``seconds`` of
    fitting in all (resumed from ``last`` when it exists), with ``flicker_weight`` times the change
    of the error between consecutive frames; returns the steps taken."""
    from tqdm import tqdm

    from ..model.losses import flicker_term
    from ..train.run import trained_parameters
    from ..train.state import load_last, save_last

    s = int(model.scale)
    pool = _fitted_entries(recorded, flicker_weight > 0)
    optimizer = torch.optim.Adam(trained_parameters(model, list(model.detail_parameters())), lr=LR)
    steps, elapsed = 0, 0.0
    if last.is_file():
        _, state = load_last(last, model, optimizer)
        steps, elapsed = int(state["step"]), float(state["elapsed_s"])
        log.info("--detail: resuming the branch fit at step %d (%.0f s done)", steps, elapsed)
    # even: an encoder-decoder branch halves its crop once (the model pads whole frames itself)
    crop_h = min(CROP, *(t.shape[-2] for t in recorded.inputs)) // 2 * 2
    crop_w = min(CROP, *(t.shape[-1] for t in recorded.inputs)) // 2 * 2
    bar = tqdm(total=round(seconds), initial=min(round(elapsed), round(seconds)), unit="s", desc="fit detail",
               disable=None if progress else True)
    model.train()
    started, saved = time.monotonic() - elapsed, time.monotonic()
    while elapsed < seconds:
        x_in, display, reference, motion, before = _batch(recorded, pool, crop_h, crop_w, s, flicker_weight > 0)
        drawn = (display + model.detail_patch(x_in, (s * crop_h, s * crop_w))).clamp(0, 1)
        loss = (drawn - reference).abs().mean()
        if before is not None:
            x_prev, display_prev, reference_prev = before
            drawn_prev = (display_prev + model.detail_patch(x_prev, (s * crop_h, s * crop_w))).clamp(0, 1)
            loss = loss + flicker_weight * flicker_term(drawn - reference, drawn_prev - reference_prev, motion, None)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        steps += 1
        now = time.monotonic()
        bar.update(min(round(now - started), round(seconds)) - bar.n)
        elapsed = now - started
        if now - saved >= SAVE_EVERY_S:
            save_last(last, model, record, optimizer, {"step": steps, "epoch": 0, "elapsed_s": elapsed,
                                                       "recent_loss": float(loss.detach())})
            saved = now
    bar.close()
    model.eval()
    return steps


def _fitted_entries(recorded: Recorded, paired: bool) -> list[int]:
    """The entries a batch draws from: those with their frame before recorded when ``paired``."""
    entries = [i for i, p in enumerate(recorded.previous) if p >= 0 or not paired]
    if not entries:
        raise UserError("--detail: no two consecutive tuned frames were recorded to measure the flicker on")
    return entries


def _batch(recorded: Recorded, pool: list[int], crop_h: int, crop_w: int, s: int, paired: bool = False):
    """:data:`BATCH` random crops of random entries of ``pool``, float32: (branch input, display,
    reference, motion, before); ``before`` is the same crop of each frame before (branch input,
    display, reference) when ``paired``, else None."""
    now, motion, before = ([], [], []), [], ([], [], [])
    for k in torch.randint(0, len(pool), (BATCH,)).tolist():
        i = pool[k]
        y = int(torch.randint(0, recorded.inputs[i].shape[-2] - crop_h + 1, (1,)))
        x = int(torch.randint(0, recorded.inputs[i].shape[-1] - crop_w + 1, (1,)))
        lr, hr = (slice(y, y + crop_h), slice(x, x + crop_w)), (slice(s * y, s * (y + crop_h)), slice(s * x, s * (x + crop_w)))
        for picked, j in ((now, i), (before, recorded.previous[i])) if paired else ((now, i),):
            picked[0].append(recorded.inputs[j][:, lr[0], lr[1]])
            picked[1].append(recorded.displays[j][:, hr[0], hr[1]])
            picked[2].append(recorded.references[j][:, hr[0], hr[1]])
        motion.append(recorded.motions[i][:, lr[0], lr[1]])
    stacked = [torch.stack(p).float() for p in now]
    return (*stacked, torch.stack(motion).float(), tuple(torch.stack(p).float() for p in before) if paired else None)


def fit_detail(tuned: Path, tune_dir: Path | list[Path], out_dir: Path, minutes: float, warmup: int,
               progress: bool = True, threads: int = 0, width: int | None = None) -> Path:
    """``out_dir/model.pt``: the model at ``tuned`` with a detail branch (:data:`BRANCH`, of ``width``
    when given) fitted on ``tune_dir`` for ``minutes`` (recording included) on ``threads`` torch
    threads (``train.threads``: 0 is a share of the idle cores); kept when done, resumed from
    ``last.pt`` when cut.  A fit of another model or width in ``out_dir`` is refused in one line."""
    from ..fileio import sha256_file
    from ..train.distributed import World, cpu_threads
    from ..train.state import FINAL, LAST

    final, last, base = out_dir / FINAL, out_dir / LAST, sha256_file(tuned)
    branch = branch_settings(width)
    for done in (p for p in (final, last) if p.is_file()):
        fitted = checkpoint.read_record(done)[0].get("detail_fit") or {}
        if fitted.get("base_sha256", base) != base:
            raise UserError(f"{done} fitted a branch to another model than {tuned} (remove {out_dir} or choose another output)")
        if fitted.get("width", branch["detail_width"]) != branch["detail_width"]:
            raise UserError(f"{done} fitted a branch of width {fitted['width']}, not {branch['detail_width']} "
                            f"(remove {out_dir} or choose another output)")
    if final.is_file():
        log.info("detail branch already fitted: %s", final)
        return final
    torch.set_num_threads(cpu_threads(World(), threads))
    start = time.monotonic()
    model, record = with_empty_branch(tuned, branch)
    # in last.pt too: what it resumes
    record = {**record, "detail_fit": {"base_sha256": base, "width": branch["detail_width"], "minutes": minutes}}
    recorded = record_frames(model, tune_dir, warmup, progress)
    recording_s = time.monotonic() - start
    steps = fit_branch(model, recorded, max(0.0, minutes * 60.0 - recording_s), last, record, progress, FLICKER_WEIGHT)
    record["detail_fit"].update(frames=len(recorded.inputs), steps=steps, lr=LR, crop=CROP, batch=BATCH,
                              flicker_weight=FLICKER_WEIGHT)
    checkpoint.save(final, model, record)
    return final
