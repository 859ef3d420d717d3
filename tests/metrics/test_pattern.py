"""The fixed-pattern measure: a per-phase offset shows, a uniform error or noise does not."""

from __future__ import annotations

import numpy as np

from mnss_kit.metrics.pattern import phase_means, phase_offset


def test_a_dot_pattern_on_one_phase_is_measured_in_8_bit_levels():
    rng = np.random.default_rng(0)
    reference = rng.random((64, 96, 3))
    dotted = reference.copy()
    dotted[0::2, 1::2] += 4 / 255  # one of the four x2 phases 4 levels too bright
    # phase means: +4 on one phase, 0 on three; their mean is 1: the largest gap is 3 levels
    assert abs(phase_offset(dotted, reference, 2) - 3.0) < 1e-9
    means = phase_means(dotted, reference, 2) * 255
    np.testing.assert_allclose(means, [[0, 4], [0, 0]], atol=1e-9)


def test_uniform_error_and_fine_noise_have_no_phase_offset():
    rng = np.random.default_rng(1)
    reference = rng.random((120, 160, 3))
    assert phase_offset(reference + 0.05, reference, 2) < 1e-9  # a global offset is not a pattern
    noisy = reference + rng.normal(0, 2 / 255, reference.shape)
    assert phase_offset(noisy, reference, 2) < 0.1  # zero-mean noise averages out over 4800 pixels a phase
    assert phase_offset(reference[:-1, :-1], reference[:-1, :-1], 3) == 0.0  # sizes not a multiple of the scale
