"""A dynamic law's burn-in: the rows from each restart of its states to the joint's first reversal,
which neither its cost nor its metrics count while the states run through them."""

from __future__ import annotations

import numpy as np

from frictionid_core.preprocess import Preprocessing
from frictionid_core.systems import burn_in_rows, get_system, observe
from frictionid_core.timeseries import JointSeries


def test_the_rows_up_to_the_first_reversal_against_the_first_motion():
    """Two stretches (a 1 s gap restarts the states): the first starts moving forward and reverses at
    row 30 (rows 0–29), the second starts at rest, moves back from row 5 and forward from row 40 (rows
    0–39: rest rows count as the way it was going)."""
    t = np.concatenate([np.arange(500) * 0.01, 6.0 + np.arange(500) * 0.01])
    v = np.zeros(1000)
    v[:30], v[30:500] = 0.2, np.where(np.arange(470) % 100 < 50, -0.2, 0.2)
    v[505:540], v[540:] = -0.2, 0.2
    rows = burn_in_rows(v[:, None], t, np.array([0.01]))
    expected = np.zeros(1000, dtype=bool)
    expected[:30] = expected[500:540] = True
    np.testing.assert_array_equal(rows[:, 0], expected)


def test_none_where_the_reversal_comes_late_or_never():
    """A reversal after more than a tenth of the stretch (row 120 of 1000) and a joint that never
    reverses (a ramp): no burn-in; a second joint's own rows are its own."""
    t = np.arange(1000) * 0.01
    late = np.where(np.arange(1000) < 120, 0.3, -0.3)
    ramp = np.full(1000, 0.3)
    early = np.where(np.arange(1000) < 80, -0.3, 0.3)
    rows = burn_in_rows(np.column_stack([late, ramp, early]), t, np.full(3, 0.01))
    assert not rows[:, :2].any()
    assert rows[:, 2].sum() == 80 and rows[:80, 2].all()


def _sweep(rate: float = 1000.0, seconds: float = 20.0) -> JointSeries:
    """A friction-only joint swept at 0.5 Hz, q = 0.5·sin(πt + 1) rad."""
    t = np.arange(int(seconds * rate)) / rate
    q = 0.5 * np.sin(np.pi * t + 1.0)
    qd = 0.5 * np.pi * np.cos(np.pi * t + 1.0)
    return JointSeries(t, ["a"], q[:, None], (2.0 * qd + np.sign(qd))[:, None], source="sweep")


def test_an_observation_for_a_dynamic_law_leaves_the_burn_in_out_of_its_every_row_copy():
    """Trimmed by 0.5 s the sweep starts moving back and reverses at t = (3π/2 − 1)/π = 1.18 s:
    the every-row copy (and its sampled rows) leaves out the ~0.68 s before, keeping their velocity for
    the states; the fit rows and a static law's observation are untouched."""
    settings = Preprocessing(cutoff_hz=10.0, decimate=1, trim_start_s=0.5, trim_end_s=0.5, min_speed={"a": 1e-3})
    system = get_system("friction-only")
    dynamic = observe(_sweep(), system, settings, all_rows=True)
    static = observe(_sweep(), system, settings)
    full = dynamic.full
    reversal = (1.5 * np.pi - 1.0) / np.pi - 0.5  # s after the first kept row (0.5 s)
    left_out = full.t[~full.used]
    assert left_out.min() == full.t[0] and abs(left_out.max() - full.t[0] - reversal) < 0.03
    assert dynamic.report["burn_in_rows"]["a"] == (~full.used).sum()
    assert np.all(full.velocity[~full.used, 0] < 0.0) and not full.y[~full.used].any()
    sampled = full.sampled if full.sampled is not None else full
    assert sampled.t[~sampled.used].max() <= left_out.max()
    np.testing.assert_array_equal(dynamic.used, static.used)
    assert static.report["burn_in_rows"]["a"] == 0
