"""Thinned analysis rows after a dip refit (Preprocessing.thin): every row where a dip is crossed
fast, coarse rows elsewhere, weights that keep the cost an integral over time."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.model import build_observation
from frictionid_core.preprocess import DIP_WINDOW, Prepared, Preprocessing, decimate, thinned_rows, window_means


def test_thinned_rows_keep_fast_crossings_and_weigh_the_rest():
    """One joint at 1 kHz analysis rate: a fast reversal (10 rad/s² through v = 0 at row 500),
    a slow one (0.05 rad/s² at row 1500) and a plateau. vs 0.05, decimate 1, thin 10: the coarse
    rate (100 Hz) follows a dip, with the margin of 2, only below 0.4·1000/(2·6·10)·π·0.05 =
    0.52 rad/s², so the fast
    crossing keeps every row within DIP_WINDOW·vs plus 10 rows each side; the rest one in ten."""
    nd, fs = 2000, 1000.0
    t = np.arange(nd) / fs
    qd = np.where(t < 1.0, 10.0 * (t - 0.5), 0.05 * (t - 1.5))[:, None]
    qdd = np.where(t < 1.0, 10.0, 0.05)[:, None]
    settings = Preprocessing(cutoff_hz=10.0, decimate=1, trim_start_s=0, trim_end_s=0, min_speed=0, thin=10,
                             dip_scale={"a": 0.05})
    index, weight, level = thinned_rows(qd, qdd, fs, settings, ["a"])
    fine = level == 1
    window = np.flatnonzero(np.abs(qd[:, 0]) < DIP_WINDOW * 0.05)
    window = window[window < 1000]  # the fast crossing only
    dense = np.arange(window[0] - 10, window[-1] + 11)
    assert np.all(np.isin(dense, index)) and np.all(fine[np.isin(index, dense)])
    coarse = np.arange(nd - 1, -1, -10)[::-1]  # aligned to the last row, as decimation
    assert np.all(np.isin(coarse, index))
    assert index.size == np.union1d(dense, coarse).size  # nothing else: the slow crossing is coarse
    # weights: √(rows each kept row stands for); the squares sum to the rows from the first kept one
    assert np.sum(weight**2) == pytest.approx(nd - index[0], abs=1e-9)
    assert np.all(weight[fine & (np.diff(index, append=nd) == 1)] == 1.0)
    # thin 1: every row, weight 1
    index, weight, level = thinned_rows(qd, qdd, fs, Preprocessing(decimate=1, thin=1), ["a"])
    assert np.array_equal(index, np.arange(nd)) and np.all(weight == 1.0) and np.all(level == 1)


def test_thinned_rows_take_the_coarsest_decimation_each_crossing_allows():
    """vs 0.05 at 1 kHz, decimate 1, thin 10 (decimations 1, 2, 5, 10): a crossing at 0.8 rad/s²
    allows ⌊0.4·1000·π·0.05/(2·6·0.8)⌋ = 6, so decimation 5 rows (one in five) within 3·vs of it;
    at 1.5 rad/s², 3 → decimation 2; at 10 rad/s², 0 → every row."""
    fs, settings = 1000.0, Preprocessing(decimate=1, thin=10, dip_scale={"a": 0.05})
    for a, expect in ((0.8, 5), (1.5, 2), (10.0, 1)):
        t = np.arange(4000) / fs
        qd = (a * (t - 2.0))[:, None]
        index, weight, level = thinned_rows(qd, np.full_like(qd, a), fs, settings, ["a"])
        crossing = np.abs(qd[index, 0]) < DIP_WINDOW * 0.05
        assert np.all(level[crossing] == expect), a
        assert np.all(np.diff(index[crossing]) == expect)
        assert np.sum(weight**2) == pytest.approx(4000 - index[0], abs=1e-9)


def test_thinned_observation_rows_are_the_fine_or_coarse_decimation_weighted():
    """build_observation with thin: each row comes from the decimation thinned_rows gives it (here
    by ``decimate`` at the reversals, its anti-alias filter; ``decimate × thin`` elsewhere, the mean
    of the samples the row stands for), times its weight; the velocity is not weighted; the dip mask
    carries the weight; metrics rows are one in ``thin``, unweighted."""
    from frictionid_core.friction import get_model
    from frictionid_core.model import IdentificationModel

    rng = np.random.default_rng(0)
    n, dt = 6000, 1e-3
    t = np.arange(n) * dt
    qd = np.sin(2 * np.pi * 0.5 * t)[:, None] * np.array([1.0, 0.5])
    qdd = np.gradient(qd, dt, axis=0)
    tau = 2.0 * qd + np.sign(qd) + 0.01 * rng.standard_normal(qd.shape)
    rigid = np.vstack([qdd[:, :1], qdd[:, 1:]])  # one rigid column shared by both joints
    prep = Prepared(t, np.cumsum(qd, axis=0) * dt, qd, qdd, tau, dt)
    settings = Preprocessing(cutoff_hz=5.0, decimate=2, trim_start_s=0, trim_end_s=0, min_speed=0, thin=5,
                             dip_scale={"a": 0.05, "b": 0.05})
    obs = build_observation(prep, ["a", "b"], rigid, ["J"], settings)
    index, weight, level = thinned_rows(prep.qd[1::2], prep.qdd[1::2], 1 / dt, settings, ["a", "b"])
    assert set(level) == {2, 10} and np.array_equal(obs.weight, weight)
    fine = level == 2
    nd = index.size
    for j in range(2):
        fine_tau, coarse_tau = decimate(tau[:, j], 2), window_means(tau[:, j], 10)
        coarse_of = coarse_tau.size - 1 - (fine_tau.size - 1 - index[~fine]) // 5
        expect = np.empty(nd)
        expect[fine], expect[~fine] = fine_tau[index[fine]], coarse_tau[coarse_of]
        np.testing.assert_allclose(obs.y[j * nd : (j + 1) * nd], expect * weight, rtol=1e-12)
    np.testing.assert_allclose(obs.velocity[fine], decimate(qd, 2)[index[fine]], rtol=1e-12)
    np.testing.assert_array_equal(obs.sampled.y[:obs.sampled.n_samples], tau[1::2][::-1][::5][::-1, 0])
    assert obs.sampled.weight is None
    model = IdentificationModel(obs, get_model("stribeck", False))
    # the dip's sign is the weighted decimated sign column (its step anti-aliased as the effort's)
    np.testing.assert_array_equal(model._dips[0].mask, obs.columns[0]["S"])
