"""The shipped model on a static camera, where a temporal method's flicker shows first."""

from __future__ import annotations

from mnss_kit.eval.baselines import baseline_methods
from mnss_kit.eval.methods import model_method, no_history_method
from mnss_kit.eval.loop import evaluate
from mnss_kit.model import checkpoint


def test_shipped_model_accumulates_on_a_static_camera_without_flicker(static_sequence):
    """Against the same weights without history and against bicubic: the history must lower the
    frame-to-frame change (temporal error) and raise IF-SSIM, not add flicker of its own.

    This pattern is not like the training frames (TAAU stays ahead here: IF-SSIM 0.9951 against
    the model's 0.9942 when this was written); the rendered static sequence of docs/mnss_x2_results.md
    is where the margins are measured.
    """
    model, _ = checkpoint.load("mnss_x2")
    methods = {"model": model_method(model), "single": no_history_method(model), **baseline_methods(2, ("bicubic",))}
    stats = evaluate(methods, static_sequence, progress=False)["methods"]
    for other in ("single", "bicubic"):
        assert stats["model"]["temporal_error"] < 0.5 * stats[other]["temporal_error"], (other, stats)
        assert stats["model"]["if_ssim"] > stats[other]["if_ssim"] + 0.03, (other, stats)
    assert stats["model"]["psnr"] > stats["bicubic"]["psnr"] + 3.0, stats
