"""Effort alignment (io.align), the stamp-gap estimate (io.checks.stamp_gaps) and JointSeries.take."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.errors import InputError
from frictionid_core.io import align_effort, stamp_gaps
from frictionid_core.timeseries import JointSeries


def _series(n: int = 50, dt: float = 1e-3) -> JointSeries:
    t = np.arange(n) * dt
    return JointSeries(t, ["a", "b"], np.column_stack([t, -t]), np.full((n, 2), np.nan),
                       velocity=np.ones((n, 2)), source="js", extras={"qg": t * 2})


def test_take_picks_rows_of_every_field():
    s = _series(10)
    mask = np.zeros(10, bool)
    mask[[1, 4, 7]] = True
    for index in (mask, np.array([1, 4, 7])):
        out = s.take(index)
        assert list(out.t) == list(s.t[[1, 4, 7]]) and out.position.shape == (3, 2) and out.velocity.shape == (3, 2)
        assert list(out.extras["qg"]) == list(s.extras["qg"][[1, 4, 7]]) and out.source == "js"
    out.notes.append("x")
    assert s.notes == []  # a copy


def test_align_interpolates_a_linear_stream_exactly_and_keeps_the_input():
    s = _series()
    te = np.arange(60) * 1e-3 - 0.5e-3  # half a period early, covering every joint state
    rng = np.random.default_rng(0)
    order = rng.permutation(te.size)  # any order
    eff = np.column_stack([3.0 + te, 7.0 - 2 * te])
    out = align_effort(s, te[order], eff[order], "effort topic '/e'")
    assert len(out) == len(s) and out.notes == []
    np.testing.assert_allclose(out.effort, np.column_stack([3.0 + s.t, 7.0 - 2 * s.t]), rtol=0, atol=1e-12)
    assert np.isnan(s.effort).all()  # the input series is not modified


def test_align_drops_joint_states_outside_the_stream_with_a_note():
    s = _series()
    te = s.t[10:40]
    out = align_effort(s, te, np.column_stack([te, te]), "effort topic '/e'")
    assert len(out) == 30 and out.t[0] == s.t[10] and out.t[-1] == s.t[39]
    assert out.notes == ["20 joint-state samples outside the time range of effort topic '/e' dropped"]
    np.testing.assert_allclose(out.effort[:, 0], out.t, rtol=0, atol=1e-15)


def test_align_at_other_times_pairs_by_those_times():
    """``at``: the joint states' times on the stream's clock (the node's receipt times)."""
    s = _series()
    at = 100.0 + s.t + 0.2e-3  # another clock, received 0.2 ms after the stamp
    te = 100.0 + np.arange(-1, 52) * 1e-3
    out = align_effort(s, te, np.column_stack([te, 2 * te]), "effort topic '/e'", at=at)
    assert len(out) == len(s)
    np.testing.assert_allclose(out.effort[:, 1], 2 * at, rtol=0, atol=1e-10)


def test_align_errors_name_the_series_and_the_stream():
    s = _series()
    with pytest.raises(InputError, match=r"js: too little data: effort topic '/e' overlaps only 2 of 50"):
        align_effort(s, s.t[:2], np.zeros((2, 2)), "effort topic '/e'")
    with pytest.raises(InputError, match=r"overlaps only 30 of 50 .*need at least 40"):
        align_effort(s, s.t[:30], np.zeros((30, 2)), "effort topic '/e'", min_samples=40)
    with pytest.raises(InputError, match=r"js: effort topic '/e' has no samples"):
        align_effort(s, np.empty(0), np.empty((0, 2)), "effort topic '/e'")
    with pytest.raises(InputError, match=r"shape \(50, 3\) for 50 stamps and 2 joints"):
        align_effort(s, s.t, np.zeros((50, 3)), "effort topic '/e'")


def test_stamp_gaps_counts_lost_samples():
    s = _series(1000)
    g = stamp_gaps(s)
    assert (g.gaps, g.missing, g.missing_pct, g.samples) == (0, 0, 0.0, 1000)
    assert g.period == pytest.approx(1e-3)
    keep = np.ones(1000, bool)
    keep[100:110] = keep[500:502] = keep[800] = False  # 13 samples in 3 gaps
    g = stamp_gaps(s.take(keep))
    assert (g.gaps, g.missing, g.samples) == (3, 13, 987)
    assert g.longest == pytest.approx(11e-3) and g.missing_pct == pytest.approx(1.3)
    assert str(g) == "about 13 of 1000 samples (1.30 %) lost or late (3 gaps, longest 11.0 ms at a 1 ms period)"
    jitter = s.take(np.arange(1000))
    jitter.t = jitter.t + np.where(np.arange(1000) % 2, 0.1e-3, 0.0)  # 1.1 / 0.9 ms intervals: no gap
    assert stamp_gaps(jitter).gaps == 0
