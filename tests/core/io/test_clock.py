"""Stamps that scatter around a clock the samples were taken on (a driver stamping at receipt) are
replaced by that clock; samples really taken at their irregular stamps keep them (io/checks.py)."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.io import check_series
from frictionid_core.timeseries import JointSeries


def sampled(on_the_clock: bool, seed: int = 0, n: int = 4000, rate: float = 500.0) -> JointSeries:
    """Two joints of smooth motion; stamps scattered by 0.3 periods around a 500 Hz clock. On the
    clock: the samples at the clock's instants (the stamps wrong); else at the stamps (the clock wrong)."""
    rng = np.random.default_rng(seed)
    clock = np.arange(n) / rate
    stamps = clock + rng.normal(0.0, 0.3 / rate, n)
    at = clock if on_the_clock else stamps
    q = np.column_stack([0.5 * np.sin(2 * np.pi * 0.4 * at), 0.3 * np.cos(2 * np.pi * 0.7 * at + 1.0)])
    effort = np.column_stack([np.cos(at), np.sin(at)])
    return JointSeries(stamps, ["a", "b"], q, effort, source="log")


def test_stamps_that_scatter_around_the_samples_clock_are_replaced_by_it():
    with pytest.warns(UserWarning, match=r"log: the time stamps scatter by 0\.4.* smoother on a uniform clock"):
        s = check_series(sampled(on_the_clock=True))
    assert len(s) == 4000  # no sample re-sorted away or dropped
    assert np.allclose(np.diff(s.t), np.diff(s.t).mean(), rtol=1e-9, atol=1e-12)


def test_samples_taken_at_their_irregular_stamps_keep_them():
    with pytest.warns(UserWarning) as record:
        s = check_series(sampled(on_the_clock=False))
    assert not [w for w in record if "uniform clock" in str(w.message)]
    assert np.std(np.diff(s.t)) > 0.1 / 500.0  # still the stamps (re-sorted where they stepped back)
