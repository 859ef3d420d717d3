"""Small frames and tiny models for the model tests."""

import torch

TINY = dict(recon_width=4, recon_layers=2, aa_width=4, aa_layers=2)


def make_frame(n=2, h=6, w=8, reset=0.0, seed=0, jitter=None):
    g = torch.Generator().manual_seed(seed)
    return {
        "color": torch.rand(n, 3, h, w, generator=g),
        "depth": torch.rand(n, 1, h, w, generator=g),
        "motion": torch.randn(n, 2, h, w, generator=g),
        "jitter": torch.rand(n, 2, generator=g) - 0.5 if jitter is None else jitter,
        "reset": torch.full((n,), float(reset)),
    }


def randomise(model, seed=0):
    """Non-zero weights everywhere (fresh nets start with a zero last layer, which hides bugs)."""
    g = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for p in model.parameters():
            p.copy_(torch.randn(p.shape, generator=g) * 0.3)
    return model
