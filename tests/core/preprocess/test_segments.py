"""Clock jumps and gaps: a log is cut into segments filtered alone (never resampled whole onto a
coarse grid); stamps after a jump back are moved to follow; too-short segments are left out."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from frictionid_core.errors import InputError
from frictionid_core.identification import IdentifyRequest, PreprocessingOverrides, identify
from frictionid_core.io import check_series
from frictionid_core.timeseries import JointSeries, sample_period
from support.data import emps_like

HOUR = 3600.0


def noisy(n: int = 8000, seed: int = 0) -> JointSeries:
    rng = np.random.default_rng(seed)
    s = emps_like(n=n)
    s.position = s.position + 2e-6 * rng.standard_normal(s.position.shape)
    s.effort = s.effort + 0.5 * rng.standard_normal(s.effort.shape)
    return s


def with_times(s: JointSeries, t: np.ndarray) -> JointSeries:
    return JointSeries(t, list(s.joints), s.position, s.effort, source="jumpy")


def checked(series: JointSeries) -> JointSeries:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return check_series(series)


def test_sample_period_and_segments_from_the_stamps():
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.77e-2, 1.23e-2, 1000))  # jittered 100 Hz, as the TIAGo log
    s = JointSeries(t, ["a"], np.zeros(t.size), np.zeros(t.size))
    assert sample_period(t) == pytest.approx(1e-2, rel=0.01) and s.segment_bounds() == [(0, 1000)]
    assert s.segments()[0] is s
    t[400:] += 0.5  # a 0.5 s pause: 50 periods
    t[700:] += 0.08  # 9 periods: lost samples, interpolated, no cut
    s = JointSeries(t, ["a"], np.zeros(t.size), np.zeros(t.size))
    assert sample_period(t) == pytest.approx(1e-2, rel=0.02) and s.segment_bounds() == [(0, 400), (400, 1000)]
    # stamps in bursts (a recorder's receipt times): 10 messages 10 µs apart every 10 ms: no cut
    bursts = (np.arange(1000) // 10) * 1e-2 + (np.arange(1000) % 10) * 1e-5
    assert JointSeries(bursts, ["a"], np.zeros(1000), np.zeros(1000)).segment_bounds() == [(0, 1000)]


@pytest.mark.parametrize("jump", [HOUR, -HOUR, -2.0])
def test_a_clock_jump_splits_the_log_and_the_fit_stays(jump):
    """A clock jump of +1 h, −1 h or −2 s (back into the samples already recorded) at 4 s of an 8 s
    log: two segments filtered alone; the fit is the clean one's within its own σ."""
    s = noisy()
    clean = identify(s, IdentifyRequest(system="joint"))
    t = s.t.copy()
    t[4000:] += jump
    series = checked(with_times(s, t))
    assert np.all(np.diff(series.t) > 0) and len(series.segments()) == 2
    np.testing.assert_array_equal(series.position, s.position)  # nothing re-sorted
    if jump < 0:
        assert series.notes[0].startswith(f"jumpy: the clock of the time stamps jumps back 1 time(s) "
                                          f"({-jump - 1e-3:.6g} s back after t = 3.999 s)")
    fit = identify(series, IdentifyRequest(system="joint"))
    report = fit.preprocessing
    assert report["sample_rate_hz"] == pytest.approx(1000.0, rel=1e-9)  # never a resample onto a coarse grid
    seam = pytest.approx(5 / min(report["cutoff_hz"].values()))  # the lowest joint's cut-off
    assert report["segments"] == {"used": 2, "left_out": 0, "trim_at_gaps_s": seam}
    for name, value in clean.params.items():
        assert abs(fit.params[name] - value) < 3 * clean.std[name], name
    gap = series.t[4000] - series.t[3999]
    assert any(w.startswith(f"jumpy: the time stamps have 1 gap(s) longer than 10 sample periods and 0.2 s "
                            f"({gap:.4g} s after 3.999 s): 2 segments, each filtered alone") for w in fit.warnings)


def test_a_segment_too_short_to_filter_is_left_out_with_its_time_and_length():
    s = noisy()
    t = s.t.copy()
    t[5000:] += 60.0  # a pause of a minute …
    t[5008:] += 60.0  # … 8 samples, and another
    fit = identify(checked(with_times(s, t)), IdentifyRequest(system="joint"))
    assert fit.preprocessing["segments"]["left_out"] == 1
    note = next(w for w in fit.warnings if "gap(s)" in w)
    assert "3 segments" in note and "1 too short for that left out (from 65 s (8 samples, 0.007 s)" in note


def test_the_longest_segment_too_short_is_an_error():
    s = noisy(n=600)
    t = s.t.copy()
    for k in range(10, 600, 10):
        t[k:] += 10.0  # segments of 10 samples
    with pytest.raises(InputError, match=r"jumpy: 10 samples are too few for the order-4 Butterworth filter"):
        identify(checked(with_times(s, t)), IdentifyRequest(system="joint"))


def test_a_cutoff_at_or_above_nyquist_is_an_error():
    with pytest.raises(InputError, match=r"synthetic: cut-off 500 Hz at or above the Nyquist frequency 500 Hz of data "
                                         r"sampled at 1000 Hz"):
        identify(noisy(2000), IdentifyRequest(system="joint", preprocessing=PreprocessingOverrides(cutoff_hz=500.0)))


def test_bursts_of_lost_messages_are_interpolated_not_cut():
    """Messages lost in bursts of 15 ms every 0.4 s (a live stream under load): shorter than
    SEGMENT_GAP_S, no cut (each would cost the trims of the filters); the fit stays the clean one's."""
    s = noisy()
    clean = identify(s, IdentifyRequest(system="joint"))
    keep = np.ones(len(s), dtype=bool)
    for k in range(400, len(s), 400):
        keep[k:k + 15] = False
    fit = identify(s.take(keep), IdentifyRequest(system="joint"))
    assert "segments" not in fit.preprocessing
    for name, value in clean.params.items():  # within 1 %: the interpolated 4 % of the data bias a little
        if name == "offset":  # a force level about 0: within 0.5 % of the Coulomb level it is told from
            assert fit.params[name] == pytest.approx(value, abs=5e-3 * clean.params["Fc"]), name
        else:
            assert fit.params[name] == pytest.approx(value, rel=1e-2), name


@pytest.mark.slow
def test_the_segments_together_must_excite_the_robot():
    """12 s of the TX40 excitation in pieces of 1 s between pauses of 1 s: a piece alone may not
    excite the 52 base parameters (it leaves directions unresolved), the pieces together do."""
    from frictionid_core.identification import build_model
    from frictionid_core.identification.identifiability import identifiability
    from frictionid_core.io import load
    from support.data import BAGS

    log = load(BAGS / "tx40_excitation").slice(0, 12_000)
    partial = 0
    for k in range(0, 12_000, 1000):
        ident = identifiability(build_model(log.slice(k, k + 1000), "tx40", "coulomb", False))
        partial += ident.rank < ident.columns
    assert partial >= 1
    t = log.t + np.repeat(np.arange(12), 1000) * 1.0  # a pause of 1 s after each piece
    paused = checked(JointSeries(t, log.joints, log.position, log.effort, source="paused"))
    fit = identify(paused, IdentifyRequest(system="tx40"))
    seam = fit.preprocessing["segments"]["trim_at_gaps_s"]
    assert fit.preprocessing["segments"] == {"used": 12, "left_out": 0, "trim_at_gaps_s": seam}
    assert seam == pytest.approx(5 / min(fit.preprocessing["cutoff_hz"].values()))
    assert fit.identifiability["unresolved"] == [] and fit.identifiability["action"] is None
    whole = identify(log, IdentifyRequest(system="tx40"))
    assert fit.metrics["relerr_pct"] < 1.5 * whole.metrics["relerr_pct"]  # each at its own rates
