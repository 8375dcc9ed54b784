"""The drift test: its in-control false-alarm rate is the stated one, realistic drifts alarm within 5 logs,
a covariate is regressed out, and the baseline resists a bad fit."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.fleet.config import AlarmSettings, FleetConfig, RobotConfig
from frictionid_core.fleet.drift import (
    CALIBRATION_WINDOW,
    SeriesTest,
    cusum,
    evaluate_series,
    fleet_drift,
    peak_first_alarm_rate,
    robust_baseline,
    threshold,
)

B = 10
REFERENCE = 2.5


def running_max(values: np.ndarray, b: int = B, reference: float = REFERENCE) -> np.ndarray:
    """max(S⁺, S⁻) so far after each monitored log of series (rows), baselines from their first b values."""
    centre, spread = robust_baseline(values[:, :b])
    upper, lower = cusum((values[:, b:] - centre[:, None]) / spread[:, None], reference)
    return np.maximum.accumulate(np.maximum(upper, lower), axis=1)


@pytest.mark.parametrize("rate", [0.01, 0.001])
def test_in_control_false_alarm_rate_is_the_stated_one(rate):
    # Fresh in-control series (another seed than the calibration's), through the same statistics: the
    # probability per log of a (first) false alarm peaks at the stated rate, within Monte-Carlo error
    # (≥ 800 alarms per window: ±4 %); the factor of 2 leaves room for it, not for a wrong threshold
    # (the threshold for a known baseline, 0.8 at 0.001, gives about 30× the rate on these series).
    h = threshold(rate, B, REFERENCE)
    n = int(800 / (rate * CALIBRATION_WINDOW))
    rng = np.random.default_rng(12345)
    values = 3.0 + 0.04 * rng.standard_normal((n, B + 60))
    maxima = running_max(values)
    peak = peak_first_alarm_rate(maxima, h)
    assert rate / 2 <= peak <= 2 * rate, (peak, rate, h)
    over_30 = np.mean(maxima[:, 29] > h) / 30
    assert over_30 <= 1.2 * rate, over_30  # the peak is the worst log: fewer alarms on average


def records(values: np.ndarray, sigmas: np.ndarray, robot: str, joints: list[str], covariate=None) -> list[dict]:
    """Fleet records of one robot: values (logs, joints) of Fc."""
    out = []
    for k, (row, sig) in enumerate(zip(values, sigmas)):
        out.append({"robot": robot, "log": f"{robot}/day_{k:03d}.mcap", "start_ns": k,
                    "start_time": f"2026-01-{k % 28 + 1:02d}T08:00:00+00:00",
                    "rows": [[j, "Fc", float(v), float(s)] for j, v, s in zip(joints, row, sig)],
                    "covariates": {} if covariate is None else {"temperature": {"*": float(covariate[k])}}})
    return out


def config(robots: list[str], rate: float, parameters=("Fc",)) -> FleetConfig:
    return FleetConfig(path=None, robots=tuple(RobotConfig(r, (), {}) for r in robots), baseline_logs=B,
                       alarm=AlarmSettings(tuple(parameters), rate, REFERENCE))


def test_the_rate_is_per_robot_parameter_and_log_through_the_fleet_test():
    # 400 in-control 3-joint robots × 40 logs (per-fit σ below the spread between logs, as for real
    # logs whose friction varies by day): first alarms per robot and log within a factor 2 of the
    # stated rate (the joints share it), counted over the 30 logs after the baseline.
    rate, robots, joints = 0.01, 400, ["j1", "j2", "j3"]
    rng = np.random.default_rng(7)
    all_records, names = [], [f"arm{r:03d}" for r in range(robots)]
    for name in names:
        values = 5.0 + 0.05 * rng.standard_normal((40, 3))
        all_records += records(values, np.full((40, 3), 0.01), name, joints)
    tests = fleet_drift(config(names, rate), all_records)
    assert len(tests) == robots * 3
    alarms = sum(t.alarm is not None for t in tests)
    per_log = alarms / (robots * 30)
    assert rate / 2 <= per_log <= 2 * rate, (alarms, per_log)


@pytest.mark.parametrize("size, ramp", [(0.10, 5), (0.20, 10), (0.30, 15)])
def test_realistic_drifts_alarm_within_five_logs(size, ramp):
    # Fc of one joint of a 3-joint robot rises by size over ramp logs (2 % a log) from log 25; the logs
    # scatter by 0.5 % (day-to-day friction once the temperature is regressed out, as in the synthetic
    # fleets), each fit resolves 0.3 %. 200 such robots: at least 98 % alarm on the drifting joint within 5
    # logs of the drift's start (the 2 % left cover a baseline whose spread came out high by chance:
    # 1σ of a 10-log MAD is ~40 %), and hardly any on the steady joints before the drift.
    rng = np.random.default_rng(int(size * 100))
    start, delays, early = 25, [], 0
    for _ in range(200):
        values = 4.0 * (1 + 0.005 * rng.standard_normal((40, 3)))
        values[:, 1] *= 1 + size * np.clip((np.arange(40) - start + 1) / ramp, 0, 1)
        tests = fleet_drift(config(["arm"], 0.001), records(values, np.full((40, 3), 0.012), "arm",
                                                            ["j1", "j2", "j3"]))
        drifting = tests[1]
        assert drifting.alarm is not None
        delays.append(drifting.alarm - start + 1)
        early += sum(t.alarm is not None and t.alarm < start for t in tests)
    assert np.mean(np.array(delays) <= 5) >= 0.98, np.bincount(delays)
    assert early <= 2  # at 0.001 per robot and log, 200 robots × 15 logs: 3 expected at most


def test_a_covariate_is_regressed_out():
    # Fc falls 0.8 %/°C and the temperature swings ±5 °C between days: without the covariate the
    # spread is ~4 % and a +10 % drift over 10 logs takes long; with it, the residual 0.5 % spread
    # makes the same drift alarm within 3 logs, and a hot spell alone raises no alarm.
    rng = np.random.default_rng(3)
    temperature = 22 + 5 * rng.standard_normal(45)
    temperature[30:35] += 12  # a hot spell, no drift
    values = 4.0 * (1 - 0.008 * (temperature - 22))[:, None] * (1 + 0.005 * rng.standard_normal((45, 1)))
    steady = SeriesTest("arm", "j1", "Fc", [str(k) for k in range(45)], [""] * 45, values[:, 0].copy(),
                        np.full(45, 0.004), B)
    assert evaluate_series(steady, temperature[:, None], 0.001, REFERENCE).alarm is None
    drifted = values[:, 0] * (1 + 0.1 * np.clip((np.arange(45) - 20 + 1) / 10, 0, 1))
    drift = SeriesTest("arm", "j1", "Fc", [str(k) for k in range(45)], [""] * 45, drifted, np.full(45, 0.004), B)
    assert evaluate_series(drift, temperature[:, None], 0.001, REFERENCE).alarm in range(20, 23)
    blind = SeriesTest("arm", "j1", "Fc", [str(k) for k in range(45)], [""] * 45, drifted, np.full(45, 0.004), B)
    evaluate_series(blind, None, 0.001, REFERENCE)
    assert blind.alarm is None or blind.alarm > 22


def test_the_baseline_resists_a_bad_fit_and_respects_the_fit_sigma():
    values = np.array([5.0, 5.01, 4.99, 5.02, 4.98, 5.0, 5.01, 4.99, 9.0, 5.0])  # one wild fit
    centre, spread = robust_baseline(values)
    assert centre == pytest.approx(5.0, abs=0.01) and spread < 0.03
    _, floored = robust_baseline(values, np.full(10, 0.2))  # the fits cannot resolve less than 0.2
    assert floored == pytest.approx(0.2)


def test_series_without_a_full_baseline_or_spread_are_not_tested():
    short = SeriesTest("arm", "j1", "Fc", ["a"] * 5, [""] * 5, np.ones(5), np.full(5, 0.1), B)
    assert evaluate_series(short, None, 0.001, REFERENCE).note == "baseline incomplete: 5 of 10 logs"
    fixed = SeriesTest("arm", "j1", "Fc", ["a"] * 15, [""] * 15, np.ones(15), np.zeros(15), B)
    assert "zero spread" in evaluate_series(fixed, None, 0.001, REFERENCE).note
