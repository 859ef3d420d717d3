"""TensorBoard summaries (scalars and a few images), written by rank 0 only."""

from __future__ import annotations

from pathlib import Path

import torch


class Summaries:
    """A ``SummaryWriter`` on the main rank; every call is a no-op elsewhere."""

    def __init__(self, log_dir: Path | None, start_step: int):
        self.writer = None
        if log_dir is not None:
            from torch.utils.tensorboard import SummaryWriter

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
