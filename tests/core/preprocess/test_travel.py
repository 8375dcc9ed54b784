"""The travel a dynamic law's states follow (frictionid_core/preprocess/travel.py): the play keeps a
noisy dwell still, passes a motion through unchanged, keeps the timing of a reversal, and the path
between analysis rows sums the samples' steps.

Tolerances. White noise within a play of half-width 4σ moves it only at the noise's new extremes
(measured over six seeds: 0.5 to 2.6 swings of 2ε over 20 000 samples; the bound allows 5). Without noise the play is
the identity (its held samples after an extreme are given the position back): exact equality.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.preprocess import PLAY_SIGMAS, play, travel_rows
from frictionid_core.preprocess.travel import row_travel


def test_noise_at_rest_moves_the_states_by_a_few_plays_at_most():
    """20 s of white noise at 1 kHz (20 000 samples, the raw position travelling ~20 mrad back and
    forth): the play moves only at the noise's new extremes, a handful of times (a record's
    expected count grows as ln n), so its path stays within a few swings of 2ε."""
    rng = np.random.default_rng(0)
    sigma = 1e-6
    q = 0.3 + sigma * rng.standard_normal((20_000, 2))
    out = play(q, np.full(2, PLAY_SIGMAS * sigma))
    path = np.abs(np.diff(out, axis=0)).sum(axis=0)
    assert np.all(path < 5 * 2 * PLAY_SIGMAS * sigma)
    assert np.all(np.abs(np.diff(q, axis=0)).sum(axis=0) > 0.02)


def test_a_noise_free_motion_passes_unchanged_reversals_included():
    t = np.arange(0.0, 4.0, 1e-3)
    q = (1e-4 * np.sin(2 * np.pi * 1.3 * t) + 2e-3 * np.sin(2 * np.pi * 0.4 * t))[:, None]  # micro-reversals on a sweep
    np.testing.assert_array_equal(play(q, np.array([1e-6])), q)


def test_a_reversal_keeps_its_timing_under_noise():
    """A parabolic reversal with noise of a tenth of the play: after it the output is the position
    (the samples held at the extreme are given it back once the turn is certain), off by the noise."""
    rng = np.random.default_rng(1)
    t = np.arange(-0.05, 0.05, 1e-3)
    clean = -0.5 * 2.0 * t**2  # a = 2 rad/s²: 2.5 mrad travelled back in 50 ms
    sigma = 1e-7
    q = (clean + sigma * rng.standard_normal(t.size))[:, None]
    out = play(q, np.array([PLAY_SIGMAS * sigma]))[:, 0]
    after = t > 0.005
    assert np.abs(out[after] - q[after, 0]).max() <= 2 * PLAY_SIGMAS * sigma + 1e-15
    assert np.abs(out - clean).max() < 2 * PLAY_SIGMAS * sigma + 4 * sigma


def test_rows_take_the_path_and_the_shift_between_them():
    q = np.array([0.0, 1.0, 3.0, 2.0, 2.5, 2.5, 4.0])[:, None]
    path, shift = row_travel(q, np.array([0, 2, 3, 6]))
    np.testing.assert_array_equal(path[:, 0], [0.0, 3.0, 1.0, 2.0])
    np.testing.assert_array_equal(shift[:, 0], [0.0, 3.0, -1.0, 2.0])
    p2, s2 = travel_rows(q, np.array([0, 2, 3, 6]), np.zeros(1))  # no noise: the play is the identity
    np.testing.assert_array_equal(p2, path)
    np.testing.assert_array_equal(s2, shift)
