"""Pre-processing: differentiation, decimation, Butterworth low-pass, uniform resampling."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from frictionid_core.errors import InputError
from frictionid_core.preprocess import (
    Preprocessing,
    brief_runs,
    central_difference,
    decimate,
    decimation_indices,
    lowpass_position,
    prepare,
    resample_uniform,
)
from frictionid_core.timeseries import JointSeries

FS = 1000.0


def amplitude(x: np.ndarray, t: np.ndarray, f: float) -> float:
    """Amplitude of the f-Hz component of x(t), by least squares on sin/cos (+ constant)."""
    A = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t), np.ones_like(t)])
    c, *_ = np.linalg.lstsq(A, x, rcond=None)
    return float(np.hypot(c[0], c[1]))


# ------------------------------------------------------------------ differentiation
def test_central_difference_exact_on_quadratic_inside_one_sided_at_ends():
    dt = 0.01
    t = 0.3 + np.arange(50) * dt
    a, b, c = 3.0, -2.0, 0.5
    y = a * t**2 + b * t + c
    d = central_difference(y, dt)
    # Central differences are exact for a quadratic (rounding only: y ~ 10, dt = 0.01).
    np.testing.assert_allclose(d[1:-1], 2 * a * t[1:-1] + b, rtol=0, atol=1e-9)
    # Ends: first-order one-sided differences, which miss the derivative by a·dt.
    assert d[0] == pytest.approx((y[1] - y[0]) / dt, abs=1e-9)
    assert d[-1] == pytest.approx((y[-1] - y[-2]) / dt, abs=1e-9)
    assert d[0] - (2 * a * t[0] + b) == pytest.approx(a * dt, abs=1e-9)
    assert d[-1] - (2 * a * t[-1] + b) == pytest.approx(-a * dt, abs=1e-9)


def test_central_difference_is_columnwise():
    dt = 1e-3
    t = np.arange(20) * dt
    y = np.column_stack([t**2, -5 * t**2 + t])
    d = central_difference(y, dt)
    assert d.shape == y.shape
    np.testing.assert_allclose(d[1:-1, 0], 2 * t[1:-1], atol=1e-9)
    np.testing.assert_allclose(d[1:-1, 1], -10 * t[1:-1] + 1, atol=1e-9)


# ------------------------------------------------------------------------ decimation
@pytest.mark.parametrize("length, n, expected", [
    (25, 10, [4, 14, 24]),
    (30, 10, [9, 19, 29]),
    (31, 10, [0, 10, 20, 30]),
    (7, 3, [0, 3, 6]),
    (8, 3, [1, 4, 7]),
])
def test_decimation_indices_every_nth_aligned_to_last(length, n, expected):
    np.testing.assert_array_equal(decimation_indices(length, n), expected)


def test_decimation_indices_match_matlab_rule_for_many_lengths():
    for n in (2, 3, 10):
        for length in range(n, 5 * n + 3):
            idx = decimation_indices(length, n)
            assert idx[-1] == length - 1
            assert np.all(np.diff(idx) == n)
            assert idx.size == int(np.ceil(length / n))  # MATLAB: ceil(nd / r) outputs
            assert 0 <= idx[0] < n


def test_decimate_keeps_the_indexed_samples_of_the_filtered_signal():
    t = np.arange(1003) / FS
    x = np.column_stack([np.sin(2 * np.pi * 2 * t), np.cos(2 * np.pi * 3 * t)])
    d = decimate(x, 10)
    sos = signal.cheby1(8, 0.05, 0.8 / 10, output="sos")
    ref = signal.sosfiltfilt(sos, x, axis=0, padlen=24)[decimation_indices(len(t), 10)]
    np.testing.assert_allclose(d, ref, rtol=0, atol=1e-12)
    assert d.shape == (101, 2)
    # MATLAB's b/a form of the same filter (the benchmark's reference) differs by rounding only at
    # n = 10 (1.3e-8 here, 2e-8 relative on the EMPS data): the EMPS figures keep every printed digit.
    b, a = signal.cheby1(8, 0.05, 0.8 / 10)
    matlab = signal.filtfilt(b, a, x, axis=0, padlen=24)[decimation_indices(len(t), 10)]
    np.testing.assert_allclose(d, matlab, rtol=0, atol=5e-8)


def test_decimate_stays_exact_at_large_factors():
    """Second-order sections keep the anti-alias filter exact where the b/a form breaks down
    (n = 60: a 6 % error in b/a form): a 0.5 Hz sine at 5 kHz passes with the DC gain."""
    fs = 5000.0
    t = np.arange(60000) / fs
    idx = decimation_indices(len(t), 60)
    out = decimate(np.sin(2 * np.pi * 0.5 * t)[:, None], 60)[:, 0]
    inner = slice(20, -20)
    assert amplitude(out[inner], t[idx][inner], 0.5) == pytest.approx(10 ** (-0.1 / 20), rel=1e-3)


def test_decimate_passes_slow_sine_with_dc_gain_and_stops_above_cutoff():
    t = np.arange(4000) / FS
    idx = decimation_indices(len(t), 10)
    b, a = signal.cheby1(8, 0.05, 0.8 / 10)
    dc_gain = (b.sum() / a.sum()) ** 2  # forward-backward: |H(0)|² = 10^(−0.1/20) ≈ 0.98855
    assert dc_gain == pytest.approx(10 ** (-0.1 / 20), rel=1e-6)
    inner = slice(20, -20)  # away from the filter's edge transients
    slow = decimate(np.sin(2 * np.pi * 1.0 * t)[:, None], 10)[:, 0]
    # 1 Hz is deep in the 40 Hz pass-band: gain = DC gain within the 0.05 dB ripple (×2) band,
    # in practice 0.98900 vs 0.98855.
    assert amplitude(slow[inner], t[idx][inner], 1.0) == pytest.approx(dc_gain, rel=1e-3)
    # 60 Hz is above the anti-alias cut-off (40 Hz at 1 kHz / 10): strongly attenuated.
    fast = decimate(np.sin(2 * np.pi * 60.0 * t)[:, None], 10)[:, 0]
    assert np.max(np.abs(fast[inner])) < 1e-3


def test_decimate_by_one_is_identity():
    x = np.arange(12.0).reshape(6, 2)
    assert decimate(x, 1) is x


def test_decimate_too_short_is_an_input_error():
    with pytest.raises(InputError, match="24 samples are too few for the anti-alias filter of decimation by 10"):
        decimate(np.zeros((24, 1)), 10)


# ----------------------------------------------------------------------- Butterworth
@pytest.mark.parametrize("f, lo, hi", [
    (5.0, 0.9999, 1.0001),   # pass-band: unchanged
    (100.0, 0.49, 0.51),     # cut-off: |H|² = 1/2 forward–backward
    (300.0, 0.0, 1e-4),      # 3× cut-off, order 4 twice: ~1e-5
])
def test_butterworth_attenuates_above_cutoff(f, lo, hi):
    t = np.arange(4000) / FS
    x = np.sin(2 * np.pi * f * t)[:, None]
    y = lowpass_position(x, FS, 100.0, order=4)[:, 0]
    inner = slice(500, 3500)
    assert lo <= amplitude(y[inner], t[inner], f) <= hi


def test_butterworth_filters_each_column():
    t = np.arange(2000) / FS
    x = np.column_stack([np.sin(2 * np.pi * 5 * t), np.sin(2 * np.pi * 300 * t)])
    y = lowpass_position(x, FS, 100.0)
    inner = slice(500, 1500)
    assert amplitude(y[inner, 0], t[inner], 5) > 0.999
    assert amplitude(y[inner, 1], t[inner], 300) < 1e-3


@pytest.mark.parametrize("cutoff", [0.0, -1.0, 500.0, 800.0])
def test_butterworth_cutoff_must_be_below_nyquist(cutoff):
    with pytest.raises(InputError, match="Nyquist"):
        lowpass_position(np.zeros((100, 1)), FS, cutoff)


# ---------------------------------------------------------------------- resampling
def test_resample_uniform_puts_jittered_stamps_on_a_grid():
    rng = np.random.default_rng(3)
    n, dt = 200, 1e-3
    t = np.arange(n) * dt + rng.uniform(-0.2, 0.2, n) * dt  # ±20 % jitter
    t[0], t[-1] = 0.0, (n - 1) * dt
    pos = np.column_stack([2.0 * t + 1.0, -t])  # linear: interpolation is exact
    eff = np.column_stack([3.0 * t, t - 1.0])
    s = JointSeries(t, ["a", "b"], pos, eff, velocity=pos, source="jit", extras={"qg": 5.0 * t})
    r = resample_uniform(s)
    assert r is not s and len(r) == n
    np.testing.assert_allclose(np.diff(r.t), dt, rtol=0, atol=1e-12)
    assert r.t[0] == t[0] and r.t[-1] == pytest.approx(t[-1], abs=1e-12)
    np.testing.assert_allclose(r.position, np.column_stack([2.0 * r.t + 1.0, -r.t]), atol=1e-12)
    np.testing.assert_allclose(r.effort, np.column_stack([3.0 * r.t, r.t - 1.0]), atol=1e-12)
    np.testing.assert_allclose(r.velocity, r.position, atol=1e-12)
    np.testing.assert_allclose(r.extras["qg"], 5.0 * r.t, atol=1e-12)
    assert len(r.notes) == 1 and "jit" in r.notes[0] and "resampled" in r.notes[0] and "1000 Hz" in r.notes[0]
    assert s.notes == []  # the input is not modified


def test_resample_uniform_leaves_regular_stamps_alone():
    n, dt = 200, 1e-3
    # 1 % jitter is below the 5 % tolerance (the EMPS stamps jitter by ~0.003 %).
    t = np.arange(n) * dt + 0.01 * dt * np.sin(np.arange(n))
    s = JointSeries(t, ["a"], t, t, source="reg")
    r = resample_uniform(s)
    assert r is s and r.notes == []
    np.testing.assert_array_equal(r.t, t)


def test_prepare_trims_and_differentiates():
    n, dt = 500, 1e-3
    t = np.arange(n) * dt
    q = 0.5 * t**2
    s = JointSeries(t, ["a"], q, np.ones(n), source="p")
    p = prepare(s, Preprocessing(cutoff_hz=1.0, decimate=1, trim_start_s=0.010, trim_end_s=0.005, min_speed=0.0,
                                 filter="none"))
    np.testing.assert_array_equal(p.t, t[10:-5])
    np.testing.assert_allclose(p.qd[:, 0], t[10:-5], atol=1e-9)
    np.testing.assert_allclose(p.qdd[:, 0], 1.0, atol=1e-6)
    assert p.dt == pytest.approx(dt)


# ------------------------------------------------------------------ brief runs of one sign of motion
def test_brief_runs_marks_the_runs_briefer_than_the_periods_of_the_cutoff():
    """At 100 Hz with a 10 Hz cut-off, half a period is 5 rows: a 2-row lobe after a stop and a
    4-row run are brief, a 5-row run and the long move are not; rows at rest (0) never are; each
    column has its own cut-off."""
    v = np.array([1.0] * 20 + [0.0] * 3 + [-0.01] * 2 + [0.0] * 4 + [0.3] * 4 + [0.0] + [-0.2] * 5 + [0.0] * 2)
    t = np.arange(v.size) / 100.0
    brief = brief_runs(np.column_stack([v, v]), t, np.array([10.0, 100.0]), 0.5)
    expected = np.zeros(v.size, dtype=bool)
    expected[23:25] = expected[29:33] = True
    np.testing.assert_array_equal(brief[:, 0], expected)
    assert not brief[:, 1].any()  # 100 Hz: half a period is half a row
    assert not brief_runs(v[:, None], t, np.array([10.0]), 0.0).any()
