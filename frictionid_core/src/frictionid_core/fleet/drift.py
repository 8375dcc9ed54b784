"""Drift of identified parameters across a robot's logs: a baseline from its first logs, then a
two-sided CUSUM whose threshold gives a stated false-alarm rate (method and assumptions: docs/fleet.md).

Per robot, joint and watched parameter, over the robot's fitted logs in the order of their first stamp:

* **baseline**, from the first ``B`` logs: centre μ0 = their median, spread s = max(1.4826·MAD, the
  median of their per-fit σ): the scatter between logs (each day's excitation, temperature and noise
  differ), never below what one fit resolves. With covariates (temperature, payload: one mean per log),
  the values are first regressed on them by least squares over the baseline logs, and the baseline
  expects μ0 + b·(c − c̄) of a log with covariates c.
* **test**, on each later log: z = (x − expected)/s, S⁺ = max(0, S⁺ + z − k), S⁻ = max(0, S⁻ − z − k);
  the series alarms at the first log where S⁺ or S⁻ exceeds the threshold h (reference k: ``alarm.reference``).
* **threshold** (:func:`threshold`): the false-alarm rate α is per robot, watched parameter and log,
  shared by the robot's J joints (α/J each). h is found by simulation, once per (B, α/J, k) and cached:
  in-control series (baseline and later logs independent, normal, equal spread) whose baseline is
  estimated exactly as above; h is the smallest threshold at which the probability that a log raises
  the series' first alarm is at most α/J at every one of the first :data:`CALIBRATION_LOGS` logs after
  the baseline (in windows of :data:`CALIBRATION_WINDOW` logs). The estimated baseline is what makes h
  large: with B = 10 its centre is off by 0.4 s and its spread by ±40 % (1σ), and a series with a
  low estimated spread alarms early; the probability peaks in the first tens of logs and falls after.
"""

from __future__ import annotations

import functools
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MAD_TO_SIGMA = 1.4826  # σ of a normal distribution = 1.4826 × its median absolute deviation
CALIBRATION_LOGS = 60  # monitored logs simulated
CALIBRATION_WINDOW = 5  # logs per window of the false-alarm probability
CALIBRATION_ALARMS = 1000  # expected first alarms per window at the threshold: ±3 % Monte-Carlo error
CALIBRATION_SERIES = (200_000, 2_000_000)  # at least, at most
CALIBRATION_CHUNK = 50_000
CALIBRATION_SEED = 20_260_101
CACHE_VERSION = 1


# ---------------------------------------------------------------- the statistics (vectorised)
def robust_baseline(values: np.ndarray, sigmas: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(centre, spread) of ``values`` along the last axis: the median and max(1.4826·MAD, the median
    of the finite ``sigmas``), both of the values' unit."""
    values = np.asarray(values, dtype=float)
    centre = np.median(values, axis=-1)
    spread = MAD_TO_SIGMA * np.median(np.abs(values - centre[..., None]), axis=-1)
    if sigmas is not None:
        sigmas = np.where(np.isfinite(sigmas), sigmas, np.nan)
        if np.isfinite(sigmas).any():
            spread = np.maximum(spread, np.nanmedian(sigmas, axis=-1))
    return centre, spread


def cusum(z: np.ndarray, reference: float) -> tuple[np.ndarray, np.ndarray]:
    """The two one-sided CUSUMs (S⁺, S⁻) after each log of standardised values ``z`` (logs along the
    last axis; S starts at 0)."""
    z = np.asarray(z, dtype=float)
    upper, lower = np.empty_like(z), np.empty_like(z)
    s_up = np.zeros(z.shape[:-1])
    s_low = np.zeros(z.shape[:-1])
    for t in range(z.shape[-1]):
        s_up = np.maximum(0.0, s_up + z[..., t] - reference)
        s_low = np.maximum(0.0, s_low - z[..., t] - reference)
        upper[..., t], lower[..., t] = s_up, s_low
    return upper, lower


# ---------------------------------------------------------------- the threshold
def calibration_series(rate: float) -> int:
    """In-control series simulated for a per-log false-alarm probability ``rate``."""
    wanted = CALIBRATION_ALARMS / (rate * CALIBRATION_WINDOW)
    low, high = CALIBRATION_SERIES
    return int(min(high, max(low, math.ceil(wanted / CALIBRATION_CHUNK) * CALIBRATION_CHUNK)))


def simulate_running_max(baseline_logs: int, reference: float, n_series: int, seed: int,
                         logs: int = CALIBRATION_LOGS) -> np.ndarray:
    """max(S⁺, S⁻) so far, after each of ``logs`` monitored logs (n_series, logs), of in-control
    series: i.i.d. N(0, 1) values whose baseline is estimated from their first ``baseline_logs``."""
    out = np.empty((n_series, logs))
    for start in range(0, n_series, CALIBRATION_CHUNK):
        rng = np.random.default_rng([seed, start])
        n = min(CALIBRATION_CHUNK, n_series - start)
        centre, spread = robust_baseline(rng.standard_normal((n, baseline_logs)))
        z = (rng.standard_normal((n, logs)) - centre[:, None]) / spread[:, None]
        upper, lower = cusum(z, reference)
        out[start:start + n] = np.maximum.accumulate(np.maximum(upper, lower), axis=1)
    return out


def peak_first_alarm_rate(running_max: np.ndarray, h: float, window: int = CALIBRATION_WINDOW) -> float:
    """The largest, over windows of ``window`` logs, probability per log that a log raises the first
    alarm at threshold ``h``, of series with these running maxima (columns: logs)."""
    survive = np.concatenate([[1.0], (running_max <= h).mean(axis=0)])
    edges = np.arange(0, running_max.shape[1] + 1, window)
    return float(np.max((survive[edges[:-1]] - survive[edges[1:]]) / window))


def _threshold_of(edge_maxima: np.ndarray, rate: float) -> float:
    """The smallest h (to 0.1 %) whose windowed first-alarm probability stays ≤ ``rate``, from the
    sorted running maxima at the window edges (columns)."""
    n = edge_maxima.shape[0]

    def peak(h: float) -> float:
        survive = np.concatenate([[1.0], [np.searchsorted(col, h, side="right") / n for col in edge_maxima.T]])
        return float(np.max(survive[:-1] - survive[1:]) / CALIBRATION_WINDOW)

    grid = np.geomspace(1e3, 1e-2, 1200)  # from high to low: stop where the probability first exceeds rate
    above = next((k for k, h in enumerate(grid) if peak(h) > rate), None)
    if above is None:
        return float(grid[-1])
    if above == 0:
        raise ValueError(f"no threshold below {grid[0]:g} gives a false-alarm rate of {rate:g}")
    low, high = float(grid[above]), float(grid[above - 1])
    while high / low > 1.001:
        mid = math.sqrt(low * high)
        low, high = (mid, high) if peak(mid) > rate else (low, mid)
    return high


def _cache_file() -> Path:
    root = os.environ.get("FRICTIONID_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "frictionid")
    return Path(root) / "cusum_thresholds.json"


@functools.lru_cache(maxsize=64)
def threshold(rate: float, baseline_logs: int, reference: float) -> float:
    """The CUSUM threshold h (spreads) for a false-alarm probability ``rate`` per series and log, a
    baseline of ``baseline_logs`` logs and the reference ``reference`` (module doc). Computed by
    simulation (~1–5 s) and kept in ``$FRICTIONID_CACHE_DIR`` (default ``~/.cache/frictionid``); the
    simulation is seeded, so every machine finds the same h."""
    n_series = calibration_series(rate)
    key = (f"v{CACHE_VERSION}|B={baseline_logs}|rate={rate!r}|k={float(reference)!r}|logs={CALIBRATION_LOGS}|"
           f"window={CALIBRATION_WINDOW}|n={n_series}|seed={CALIBRATION_SEED}")
    path = _cache_file()
    try:
        cached = json.loads(path.read_text(encoding="utf-8"))
        if isinstance(cached.get(key), float):
            return cached[key]
    except (OSError, ValueError, AttributeError):
        cached = {}
    running = simulate_running_max(baseline_logs, reference, n_series, CALIBRATION_SEED)
    edges = np.arange(CALIBRATION_WINDOW, CALIBRATION_LOGS + 1, CALIBRATION_WINDOW) - 1
    h = _threshold_of(np.sort(running[:, edges], axis=0), rate)
    try:
        from frictionid_core.files import write_json

        write_json(path, {**(cached if isinstance(cached, dict) else {}), key: h})
    except Exception:  # a cache that cannot be written only costs the next run the simulation
        pass
    return h


# ---------------------------------------------------------------- one series
@dataclass
class SeriesTest:
    """The drift test of one robot, joint and parameter over its fitted logs (in time order).

    Attributes:
        robot, joint, parameter: what is tested.
        logs, start_times: each log's name and first stamp (ISO 8601).
        values, sigmas: the identified values and their σ.
        baseline_logs: B, the logs that set the baseline.
        expected: the baseline's value for each log (μ0, plus the covariates' effect), or None
            (no baseline: fewer than B + 1 logs, or zero spread).
        spread: s, the baseline spread (values' unit), or None.
        z, upper, lower: standardised values and the CUSUMs (NaN over the baseline logs).
        threshold: h (spreads), or None.
        alarm: index of the first log where the CUSUM exceeds h, or None.
        covariates: names of the covariates regressed out.
        note: why the series was not tested ("" when it was).
    """

    robot: str
    joint: str
    parameter: str
    logs: list[str]
    start_times: list[str]
    values: np.ndarray
    sigmas: np.ndarray
    baseline_logs: int
    expected: np.ndarray | None = None
    spread: float | None = None
    z: np.ndarray | None = None
    upper: np.ndarray | None = None
    lower: np.ndarray | None = None
    threshold: float | None = None
    alarm: int | None = None
    covariates: list[str] = field(default_factory=list)
    note: str = ""

    def alarm_record(self) -> dict | None:
        """The alarm as ``alarms.json`` lists it, or None."""
        if self.alarm is None:
            return None
        k = self.alarm
        return {"robot": self.robot, "joint": self.joint, "parameter": self.parameter, "first_log": self.logs[k],
                "start_time": self.start_times[k], "baseline": float(self.expected[k]), "value": float(self.values[k]),
                "z": float(self.z[k]), "direction": "up" if self.upper[k] > self.threshold else "down",
                "spread": float(self.spread), "threshold": float(self.threshold),
                "logs_after_baseline": int(k - self.baseline_logs + 1)}


def evaluate_series(series: SeriesTest, covariates: np.ndarray | None, rate: float, reference: float) -> SeriesTest:
    """Run the test on ``series`` (in place; returned): baseline, z, CUSUMs, first alarm.
    ``covariates``: (logs, p) values regressed out, or None; ``rate``: α for this series."""
    b = series.baseline_logs
    values = series.values
    n = len(values)
    if n <= b:
        series.note = f"baseline incomplete: {n} of {b} logs" if n < b else "no log after the baseline yet"
        if n < b:
            return series
    base = slice(0, b)
    residual = values.copy()
    effect = np.zeros(n)
    if covariates is not None and covariates.shape[1] >= b - 1:
        series.note = f"{covariates.shape[1]} covariates need more than {b} baseline logs: not regressed out"
        series.covariates, covariates = [], None
    if covariates is not None and covariates.shape[1]:
        centred = covariates - covariates[base].mean(axis=0)
        design = np.column_stack([np.ones(b), centred[base]])
        coef = np.linalg.lstsq(design, values[base], rcond=None)[0]
        effect = centred @ coef[1:]
        residual = values - effect
    centre, spread = robust_baseline(residual[base], series.sigmas[base])
    centre, spread = float(centre), float(spread)
    if not spread > 0:
        series.note = "zero spread over the baseline logs (a fixed parameter?): not tested"
        return series
    series.expected = centre + effect
    series.spread = spread
    z = (values - series.expected) / spread
    z[base] = np.nan
    series.z = z
    upper, lower = (np.full(n, np.nan) for _ in range(2))
    if n > b:
        upper[b:], lower[b:] = cusum(z[b:], reference)
    series.upper, series.lower = upper, lower
    series.threshold = threshold(rate, b, reference)
    over = np.flatnonzero(np.maximum(upper[b:], lower[b:]) > series.threshold)
    series.alarm = int(b + over[0]) if over.size else None
    return series


# ---------------------------------------------------------------- the fleet
def fleet_drift(config, records: list[dict]) -> list[SeriesTest]:
    """The drift test of every robot, joint and watched parameter of a fleet run (``config``: its
    FleetConfig; ``records``: its fitted logs, each robot's in time order)."""
    alarm = config.alarm
    by_robot: dict[str, list[dict]] = {}
    for record in records:
        by_robot.setdefault(record["robot"], []).append(record)
    out = []
    for robot in config.robots:
        logs = by_robot.get(robot.name, [])
        for parameter in alarm.parameters:
            joints = list(dict.fromkeys(row[0] for r in logs for row in r["rows"] if row[1] == parameter))
            for joint in joints:
                rows = [(r, next((row for row in r["rows"] if row[0] == joint and row[1] == parameter), None))
                        for r in logs]
                rows = [(r, row) for r, row in rows if row is not None]
                series = SeriesTest(robot.name, joint, parameter, [r["log"] for r, _ in rows],
                                    [r["start_time"] for r, _ in rows], np.array([row[2] for _, row in rows]),
                                    np.array([row[3] for _, row in rows]), config.baseline_logs)
                covariates, names = _covariate_matrix([r for r, _ in rows], joint)
                series.covariates = names
                out.append(evaluate_series(series, covariates, alarm.false_alarm_rate / len(joints), alarm.reference))
    return out


def _covariate_matrix(records: list[dict], joint: str) -> tuple[np.ndarray | None, list[str]]:
    """(logs, p) means of the covariates every one of ``records`` has for ``joint`` (or for every
    joint: "*"), and their names; (None, []) without any."""
    names = sorted(set.intersection(*(set(r["covariates"]) for r in records))) if records else []
    columns, used = [], []
    for name in names:
        values = [r["covariates"][name].get(joint, r["covariates"][name].get("*")) for r in records]
        if all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
            columns.append(values)
            used.append(name)
    return (np.array(columns, dtype=float).T if columns else None), used


def alarm_list(tests: list[SeriesTest]) -> list[dict]:
    """The alarms of ``tests`` (``alarms.json``), in their order."""
    return [record for test in tests if (record := test.alarm_record()) is not None]
