"""Spikes: outlier samples found per field and joint, replaced by interpolation and named in the
warnings; clean signals (noise, steps, quantised encoders, smooth motion) left alone."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from frictionid_core.errors import InputError
from frictionid_core.identification import IdentifyRequest, identify
from frictionid_core.io.checks import check_series, find_spikes
from frictionid_core.timeseries import JointSeries
from support.data import emps_like


def noisy(n: int = 6000, seed: int = 0) -> JointSeries:
    """EMPS-like data with position noise 2 µm and force noise 0.5 N (σ)."""
    rng = np.random.default_rng(seed)
    s = emps_like(n=n)
    s.position = s.position + 2e-6 * rng.standard_normal(s.position.shape)
    s.effort = s.effort + 0.5 * rng.standard_normal(s.effort.shape)
    return s


def checked(series: JointSeries) -> tuple[JointSeries, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = check_series(series)
    return out, [str(w.message) for w in caught]


def test_a_step_at_the_last_sample_is_no_spike():
    """A synthetic log that ends at rest: friction (sign(0) = 0) vanishes at its last sample only; the
    last sample has no neighbour after it to tell that step from a spike."""
    tau = emps_like(n=3000).effort[:, 0]
    tau[-1] -= 60.0  # 30 × its largest sample-to-sample steps, within its span
    assert find_spikes(tau).size == 0
    tau[-1] = 1e6
    np.testing.assert_array_equal(find_spikes(tau), [2999])


def test_isolated_glitches_and_short_runs_are_found():
    rng = np.random.default_rng(1)
    t = np.arange(5000) * 1e-3
    x = np.sin(2 * np.pi * t) + 1e-3 * rng.standard_normal(t.size)
    x[[0, 1000, 4999]] = [1e6, -3.0, 7.0]  # at both ends too
    x[2000:2003] = 5.0  # a run of three
    np.testing.assert_array_equal(find_spikes(x), [0, 1000, 2000, 2001, 2002, 4999])


@pytest.mark.parametrize("name", ["gaussian", "laplace", "coulomb steps", "encoder at rest", "smooth", "ramp"])
def test_clean_signals_have_no_spikes(name):
    rng = np.random.default_rng(2)
    t = np.arange(20_000) * 1e-3
    v = np.cos(2 * np.pi * 0.7 * t)
    x = {"gaussian": rng.standard_normal(t.size),
         "laplace": rng.laplace(size=t.size),
         "coulomb steps": 20 * np.sign(v) + 200 * v + 0.5 * rng.standard_normal(t.size),
         # an encoder at rest, one count up now and then
         "encoder at rest": 1.0 + 1e-4 * (rng.random(t.size) < 0.002),
         "smooth": emps_like(n=t.size).effort[:, 0],
         "ramp": 3 * t}[name]
    assert find_spikes(x).size == 0


def test_check_series_replaces_spikes_by_interpolation_and_names_them():
    s = noisy()
    raw = s.take(np.arange(len(s)))
    raw.position, raw.effort = raw.position.copy(), raw.effort.copy()
    raw.position[2000, 0] = 1e6
    raw.effort[[3000, 3001], 0] = [-400.0, 900.0]
    out, warned = checked(raw)
    assert out.position[2000, 0] == pytest.approx(np.interp(s.t[2000], s.t[[1999, 2001]], s.position[[1999, 2001], 0]))
    assert out.effort[3000, 0] == pytest.approx(np.interp(s.t[3000], s.t[[2999, 3002]], s.effort[[2999, 3002], 0]))
    keep = np.setdiff1d(np.arange(len(s)), [2000, 3000, 3001])
    np.testing.assert_array_equal(out.position[keep], s.position[keep])
    np.testing.assert_array_equal(out.effort[keep], s.effort[keep])
    assert warned == out.notes and len(warned) == 1
    assert warned[0].startswith("synthetic: 3 spike sample(s) replaced by linear interpolation between their "
                                "neighbours: joint 'emps' position: 1, the largest 1e+06 at 2 s from the start")
    assert "joint 'emps' effort: 2, the largest 900 at 3.001 s" in warned[0]
    assert raw.position[2000, 0] == 1e6  # the input is left as it was


def test_a_glitch_no_longer_decides_the_fit():
    """One position of 1e6 among 6000 samples: without the repair σ_q is 2e4 and nothing "moves"; with
    it the fit is that of the clean data: every parameter within 1e-6, the same rows."""
    s = noisy()
    clean = identify(s, IdentifyRequest(system="joint"))
    raw = s.take(np.arange(len(s)))
    raw.position = raw.position.copy()
    raw.position[2000, 0] = 1e6
    with pytest.raises(InputError, match="no joint moves"):
        identify(raw, IdentifyRequest(system="joint"))
    fit = identify(checked(raw)[0], IdentifyRequest(system="joint"))
    for name, value in clean.params.items():
        assert fit.params[name] == pytest.approx(value, rel=1e-6), name
    assert fit.preprocessing["fit_rows"] == clean.preprocessing["fit_rows"]
    assert fit.preprocessing["min_speed"]["emps"] == pytest.approx(  # from the noise: one sample less
        clean.preprocessing["min_speed"]["emps"], rel=1e-2)
    assert any("1 spike sample(s)" in w and "joint 'emps' position" in w for w in fit.warnings)


def test_a_wrong_stamp_is_interpolated():
    s = noisy(2000)
    raw = s.take(np.arange(len(s)))
    raw.t = raw.t.copy()
    raw.t[700] = 1e4
    out, warned = checked(raw)
    np.testing.assert_allclose(out.t, s.t, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(out.position, s.position)
    assert warned == ["synthetic: 1 time stamp(s) out of line with both neighbours (first at sample 700) replaced by "
                      "interpolation between them"]
