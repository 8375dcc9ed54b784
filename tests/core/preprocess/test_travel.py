"""The travel a dynamic law's states follow (frictionid_core/preprocess/travel.py): the play keeps a
noisy dwell still, passes a motion through unchanged but for a hold of 2ε at its reversals, and the
path between analysis rows sums the samples' steps (a reversal the samples do not show given the
path its velocities say).

Tolerances. White noise within a play of half-width 4σ moves it only at the noise's new extremes
(measured over six seeds: 0.5 to 2.6 swings of 2ε over 20 000 samples; the bound allows 5). Where
the play moves its output is the sample itself: exact equality; it holds by at most 2ε.
"""

from __future__ import annotations

import numpy as np
import pytest

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


def test_a_motion_passes_unchanged_but_the_hold_at_its_reversals():
    """Without noise the play is the position itself along every motion (exactly: its output is the
    sample where it moves) and lags it by at most 2ε after each reversal, where it holds until the
    position has come back 2ε."""
    t = np.arange(0.0, 4.0, 1e-3)
    q = (1e-4 * np.sin(2 * np.pi * 1.3 * t) + 2e-3 * np.sin(2 * np.pi * 0.4 * t))[:, None]  # micro-reversals on a sweep
    eps = 1e-6
    out = play(q, np.array([eps]))
    moved = np.flatnonzero(np.diff(out[:, 0]) != 0.0) + 1
    np.testing.assert_array_equal(out[moved], q[moved])
    assert np.abs(out - q).max() <= 2 * eps * (1 + 1e-9)
    assert moved.size > 0.95 * t.size


def test_noise_below_the_play_does_not_turn_a_motion_back():
    """A ramp with noise of a tenth of the play: the output never steps back (no reversal the states
    would follow), and stays within 2ε of the position."""
    rng = np.random.default_rng(1)
    sigma = 1e-7
    q = (np.linspace(0.0, 2e-4, 2000) + sigma * rng.standard_normal(2000))[:, None]
    out = play(q, np.array([PLAY_SIGMAS * sigma]))[:, 0]
    assert np.all(np.diff(out) >= 0.0)
    assert np.abs(out - q[:, 0]).max() <= 2 * PLAY_SIGMAS * sigma


def test_rows_take_the_path_and_the_shift_between_them():
    q = np.array([0.0, 1.0, 3.0, 2.0, 2.5, 2.5, 4.0])[:, None]
    path, shift = row_travel(q, np.array([0, 2, 3, 6]))
    np.testing.assert_array_equal(path[:, 0], [0.0, 3.0, 1.0, 2.0])
    np.testing.assert_array_equal(shift[:, 0], [0.0, 3.0, -1.0, 2.0])
    p2, s2 = travel_rows(q, np.array([0, 2, 3, 6]), np.zeros(1))  # no noise: the play is the identity
    np.testing.assert_array_equal(p2, path)
    np.testing.assert_array_equal(s2, shift)


def test_a_reversal_between_two_samples_gets_the_path_of_its_velocities():
    """v from +1 to −1 rad/s over a 20 ms step, the position almost back where it was: the samples
    show no travel, the velocities taken linear say 5 mrad out and 5 back; a still step stays 0."""
    q = np.array([0.0, 1e-9, 0.0])[:, None]
    v = np.array([1.0, -1.0, -1.0])[:, None]
    path, shift = row_travel(q, np.arange(3), v, 0.02)
    assert path[1, 0] == pytest.approx(0.5 * (1 + 1) * 0.02 / 2)
    assert shift[1, 0] == pytest.approx(1e-9)
    still, _ = row_travel(np.zeros((3, 1)), np.arange(3), v, 0.02)
    assert np.all(still == 0.0)
