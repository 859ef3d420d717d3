"""Small random frames and the float comparison for the GPU tests."""

from __future__ import annotations

import numpy as np

from mnss_kit.gpu.reference import to_half
from mnss_kit.gpu.weights import Conv3x3
from mnss_kit.ops.jitter import jitter_sequence, period

FLOAT_ATOL = 1e-3  # float outputs: shader vs numpy reference


def pattern_jitters(pattern: str, scale: int) -> np.ndarray:
    """Every jitter of one period of ``pattern`` (float32, as the loader hands them over)."""
    return jitter_sequence(pattern, scale, period(pattern, scale)).astype(np.float32)


def random_frame(rng, h: int, w: int, scale: int, motion_scale: float = 2.0) -> dict:
    """LR colour (fp16 values), depth, motion (both signs), previous HR history (fp16 values) and LR depth."""
    return {
        "color": to_half(rng.random((h, w, 3), dtype=np.float32)),
        "depth": rng.random((h, w, 1), dtype=np.float32),
        "motion": (rng.standard_normal((h, w, 2)) * motion_scale).astype(np.float32),
        "history": to_half(rng.random((h * scale, w * scale, 3), dtype=np.float32)),
        "prev_depth": rng.random((h, w, 1), dtype=np.float32),
    }


def random_conv(rng, cout: int, cin: int, gain: float = 0.3) -> Conv3x3:
    return Conv3x3((rng.standard_normal((cout, cin, 3, 3)) * gain).astype(np.float32),
                   (rng.standard_normal(cout) * 0.1).astype(np.float32))


def assert_float_close(got: np.ndarray, want: np.ndarray, atol: float = FLOAT_ATOL) -> None:
    """``|got - want| <= atol``, or one float16 step of ``want`` where that is coarser (fp16
    storage of values above 2 cannot be closer than its own grid)."""
    got, want = np.asarray(got, np.float32), np.asarray(want, np.float32)
    assert got.shape == want.shape, (got.shape, want.shape)
    bound = np.maximum(np.float32(atol), np.spacing(np.abs(want).astype(np.float16)).astype(np.float32))
    err = np.abs(got - want)
    worst = np.unravel_index(np.argmax(err - bound), err.shape)
    assert np.all(err <= bound), f"max error {err.max():.3g} at {worst}: got {got[worst]}, want {want[worst]}"
