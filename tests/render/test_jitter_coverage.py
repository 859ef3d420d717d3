"""Every jitter pattern visits every sub-pixel of the s x s tile within its period."""

import numpy as np
import pytest

from mnss_kit.ops import jitter


@pytest.mark.parametrize("pattern,scale", [("grid", 2), ("grid", 3), ("halton", 2), ("halton", 3), ("halton", 4)])
def test_pattern_covers_every_subpixel(pattern, scale):
    n = jitter.period(pattern, scale)
    offsets = jitter.jitter_sequence(pattern, scale, n)
    assert np.all(offsets >= -0.5) and np.all(offsets < 0.5)
    sub = jitter.subpixel_index(offsets, scale)
    visited = {(int(x), int(y)) for x, y in sub}
    assert visited == {(x, y) for x in range(scale) for y in range(scale)}
    again = jitter.jitter_sequence(pattern, scale, 2 * n)
    np.testing.assert_array_equal(again[:n], again[n:])  # repeats with its period

