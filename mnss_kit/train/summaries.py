"""TensorBoard summaries (scalars and a few images), written by rank 0 only."""

from __future__ import annotations

import logging
from pathlib import Path

import torch

log = logging.getLogger(__name__)
EVENTS_GLOB = "events.out.tfevents.*"  # TensorBoard's event file names


class Summaries:
    """A ``SummaryWriter`` on the main rank; every call is a no-op elsewhere.

    A ``fresh`` run first removes the event files already in ``log_dir`` (a
    killed run's), so its curves are not drawn over another run's; a resumed
    run keeps them and continues at ``start_step``.
    """

    def __init__(self, log_dir: Path | None, start_step: int, fresh: bool = False):
        self.writer = None
        if log_dir is not None:
            from torch.utils.tensorboard import SummaryWriter

            if fresh:
                remove_events(log_dir)

            # purge_step drops events a killed run logged after its last checkpoint
            self.writer = SummaryWriter(str(log_dir), purge_step=start_step if start_step > 0 else None)

    def scalars(self, step: int, values: dict[str, float]) -> None:
        if self.writer is None:
            return
        for name, value in values.items():
            self.writer.add_scalar(name, value, step)

    def images(self, step: int, images: dict[str, torch.Tensor]) -> None:
        """``images``: name -> (3, H, W) float in [0, 1]."""
        if self.writer is None:
            return
        for name, image in images.items():
            self.writer.add_image(name, image.clamp(0.0, 1.0), step)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()


def remove_events(log_dir: Path) -> None:
    """Delete the TensorBoard event files directly in ``log_dir``, saying so in one log line."""
    old = sorted(Path(log_dir).glob(EVENTS_GLOB))
    for path in old:
        path.unlink()
    if old:
        log.info("removed %d TensorBoard event file(s) of an earlier run from %s (a fresh run starts clean)", len(old), log_dir)
