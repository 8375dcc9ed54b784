"""A lag of a log's velocity and effort behind its position — a driver that stamps them later than the
position, or a velocity filtered inside the drive — found and removed (:func:`remove_channel_lag`, a
step of every loader's checks), the lags removed kept in ``series.meta`` (:func:`lag_record`: the
result's ``preprocessing.lag_s``).

* **Velocity** (where one is logged): per joint, the logged velocity against the derivative of the
  position, both low-passed alike (zero-phase Butterworth at LAG_CUTOFF_SHARE of the sample rate, at
  most LAG_CUTOFF_HZ; EDGE_PERIODS of its period cut at the ends): the lag maximises their correlation
  (searched within ±MAX_LAG_S and MAX_LAG_SHARE of the longest segment, each shift's correlation over
  its own window, a parabola between samples). It counts when the joint moves (range above
  MOVING_FACTOR × its position noise), the correlation there is at least MIN_CORRELATION, each half
  of the log gives the same lag and so do the derivatives of the two signals (correlation at least
  MIN_SHAPE_CORRELATION), all within LAG_TOLERANCE_PERIODS sample periods or LAG_TOLERANCE_SHARE of
  the lag: a delay shifts every frequency alike. A lag within MIN_LAG_PERIODS periods and MIN_LAG_S
  is none (the real UR10e logs: up to 0.17 periods). Counted lags that agree are one lag of the
  driver, removed from every joint whose own estimate does not say otherwise; lags that differ are
  removed joint by joint. A velocity late by both measures but not by one delay (the real TIAGo's:
  ~190 ms, its changes 58–82 ms) is named and left as logged; estimates that do not hold are not
  named (the real Kinova Gen3's smooth ramps: −12 to +36 ms from one second to the next, their
  derivatives correlating at 0.5).
* **Effort**: a lag of the effort mostly biases a fit (L·Fv folds into the inertia) rather than showing
  in its residual, and a lag estimated against the identification's model is circular. What these
  data can tell is whether the effort shares the velocity's lag: each moving joint's effort is
  regressed on the motion (q̈ of the moving joints, q̇, sign q̇, 1, sin q and cos q of the moving joints:
  no system assumed), as logged and shifted by the velocity's lag; the effort shares the lag when the
  geometric mean over the joints of the residual ratio (shifted / as logged) is at most
  EFFORT_LAG_RATIO. Synthetic logs lagged 20–60 ms give 0.004–0.3; the real WidowX, whose velocity
  lags by 50 ms, 1.2 (0.87 on its waist alone), its effort as logged validating better (18.6 %
  against 21.5 % shifted); the real UR10e logs ~1 at 50 ms, and still 0.84 once lagged 60 ms on
  purpose: on noisy real logs an effort lag can go unseen, never the other way round. An effort
  that does not share the velocity's lag, or a log without a logged velocity, may lag by its own:
  the same regression, with the sines and cosines of the sums of 2 and 3 moving joints in a row
  added (a serial arm's gravity: a lagged UR5 left 0.86 of its residual without them, 0.75 with),
  at every shift of the effort within ±MAX_LAG_S (one FFT correlation per column); the shift that
  minimises the geometric mean of the residual ratios, found by the whole log and at least one half (or
  by both halves alike, their mean, where the whole log's regression finds another), is a *candidate*
  (``meta[CANDIDATE_KEY]``: :func:`effort_lag_candidate`), *confirmed by the motion* when
  it leaves at most EFFORT_SCAN_RATIO of the logged residual and both halves find it (synthetic arms
  lagged 10–60 ms: 0.02–0.56, within a tenth of a sample period at 1 kHz). The loader moves no effort
  by its own lag: the identification judges a candidate with the system's own model and law
  (:mod:`frictionid_core.identification.effort_lag`): the regression is not that model, whose misfit
  can hide a lag (a one-joint Stribeck law lagged 2 ms: 0.985) or fake one (a LuGre joint's friction,
  late at each reversal, confirmed as a 9.6 ms lag with 0.49 of the residual).
* The lagging channels are moved back onto the position's stamps (linear interpolation at t + lag,
  within each segment of the stamps); the samples the move leaves without a value (the last lag
  seconds of each segment) are dropped. One note says what was found and done.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from frictionid_core.preprocess.settings import MOVING_FACTOR
from frictionid_core.timeseries import JointSeries

MAX_LAG_S = 0.25  # lags searched within ± this …
MAX_LAG_SHARE = 0.125  # … and this share of the longest segment
LAG_CUTOFF_SHARE = 0.05  # both signals low-passed at this share of the sample rate …
LAG_CUTOFF_HZ = 20.0  # … at most this
LAG_ORDER = 4
ANALYSIS_RATE_HZ = 1000.0  # the low-passed signals are kept at (about) this rate, at most the log's
MIN_SEGMENT_SAMPLES = 200  # a longest segment shorter than this is not judged
MIN_CORRELATION = 0.95  # a joint's velocity and position derivative correlate at least this well at the peak …
MIN_SHAPE_CORRELATION = 0.9  # … and their derivatives at least this well
EDGE_PERIODS = 5.0  # the low-passed signals' ends (this many periods of the cut-off) are left out (filter transients)
LAG_TOLERANCE_PERIODS = 1.0  # lags agree within this many sample periods …
LAG_TOLERANCE_SHARE = 0.2  # … or this share of the lag
MIN_LAG_PERIODS = 1.0  # a lag within this many sample periods …
MIN_LAG_S = 2e-3  # … and this is none
EFFORT_LAG_RATIO = 0.5  # the effort shares the velocity's lag when its residual shifted is at most this × as logged
EFFORT_FIT_SHARE = 0.5  # a joint's effort is judged when the regression leaves at most this share unexplained
EFFORT_SCAN_RATIO = 0.8  # the effort's own lag: the best shift leaves at most this × the residual as logged
META_PREFIX = "lag_s/"  # series.meta["lag_s/<velocity|effort>/<joint>"]: the lag removed, s
# series.meta[CANDIDATE_KEY] (s), [CANDIDATE_RATIO_KEY] and [CANDIDATE_CONFIRMED_KEY] (1.0: the motion regression
# confirms it, 0.0: not): the effort's own lag, found by the whole log and a half of it; the identification judges it
CANDIDATE_KEY = "lag_candidate_s/effort"
CANDIDATE_RATIO_KEY = "lag_candidate_ratio/effort"
CANDIDATE_CONFIRMED_KEY = "lag_candidate_confirmed/effort"
CHANNELS = ("velocity", "effort")


def lag_record(series: JointSeries) -> dict[str, dict[str, float]] | None:
    """``{"velocity": {joint: s}, "effort": {joint: s}}``: the lags removed from the joints of
    ``series`` (0: judged, none found), None when none was judged (no logged velocity, no joint
    moving enough)."""
    out = {c: {j: float(series.meta[f"{META_PREFIX}{c}/{j}"]) for j in series.joints
               if f"{META_PREFIX}{c}/{j}" in series.meta} for c in CHANNELS}
    return out if out["velocity"] or out["effort"] else None


@dataclass(frozen=True)
class _Estimate:
    """One joint's velocity against its position's derivative (lags in s, correlations at their peaks)."""

    lag: float  # of the velocities
    r: float
    halves_agree: bool  # each half of the log gives ``lag``
    shape_lag: float | None  # of their derivatives (None: no peak inside the search)
    shape_r: float

    def credible(self, tolerance: float) -> bool:
        """A delay of the velocity: every estimate agrees."""
        return (self.r >= MIN_CORRELATION and self.halves_agree and self.shape_lag is not None
                and self.shape_r >= MIN_SHAPE_CORRELATION and abs(self.shape_lag - self.lag) <= tolerance)

    def filtered(self, threshold: float) -> bool:
        """Late by both measures, but not by one delay (a velocity filtered inside the drive)."""
        return (self.r >= MIN_CORRELATION and self.halves_agree and self.shape_lag is not None
                and self.shape_r >= MIN_SHAPE_CORRELATION and min(self.lag, self.shape_lag) >= threshold)


def remove_channel_lag(series: JointSeries) -> tuple[JointSeries, str | None]:
    """``series`` with a lag of its velocity (and effort) behind its position removed (see the
    module doc), and the note saying what was found and done (None when no lag was judged or found)."""
    if series.velocity is None:
        return _effort_only(series), None
    grid = _Grid(series)
    estimates = _velocity_estimates(series, grid)
    if not estimates:
        return series, None
    period = _period(series.t)
    threshold = max(MIN_LAG_PERIODS * period, MIN_LAG_S)
    counted = [j for j, e in estimates.items() if e.credible(_tolerance(e.lag, period))]
    lags = np.array([estimates[j].lag for j in counted])
    common = None
    if counted and np.ptp(lags) <= _tolerance(float(np.median(lags)), period):
        common = float(np.median(lags))  # one lag of the driver: every joint's but one measured otherwise
        judged = [j for j in series.joints
                  if j not in estimates or abs(estimates[j].lag - common) <= _tolerance(common, period)]
        velocity = {j: (common if j in judged and abs(common) >= threshold else 0.0) for j in series.joints}
    else:
        velocity = {j: (estimates[j].lag if j in counted and abs(estimates[j].lag) >= threshold else 0.0)
                    for j in series.joints}
        judged = counted
    meta = dict(series.meta)
    filtered = {j: e for j, e in estimates.items() if j not in counted and e.filtered(threshold)}
    if not any(velocity.values()):
        meta.update({f"{META_PREFIX}{c}/{j}": 0.0 for c in CHANNELS for j in judged})
        out = _effort_only(_with_meta(series, meta), grid)  # the velocity on time: the effort's own lag, if any
        return out, _filtered_note(series, filtered) if filtered else None
    ratio = _effort_ratio(series, grid, velocity)
    effort = velocity if ratio is not None and ratio <= EFFORT_LAG_RATIO else dict.fromkeys(series.joints, 0.0)
    if not any(effort.values()):  # not the velocity's lag: the effort's own, if it has one (a candidate)
        meta.update(_candidate_meta(_effort_scan(grid, threshold)))
    meta.update({f"{META_PREFIX}velocity/{j}": velocity[j] for j in judged})
    meta.update({f"{META_PREFIX}effort/{j}": effort[j] for j in judged})
    out, dropped = _shifted(series, velocity, effort)
    out.meta = meta
    note = _note(series, velocity, common, counted, estimates, ratio, effort, dropped)
    return out, note + (f"; {_filtered_note(series, filtered, head=False)}" if filtered else "")


def _note(series: JointSeries, velocity: dict, common: float | None, counted: list[str], estimates: dict,
          ratio: float | None, effort: dict, dropped: int) -> str:
    def by(lag: float) -> str:
        return f"{'lags' if lag > 0 else 'runs ahead of'} the position by {abs(lag) * 1e3:.3g} ms"

    shifted = [j for j in series.joints if velocity[j]]
    if common is not None:
        which = "every joint" if len(shifted) == len(series.joints) else ", ".join(shifted)
        lag = f"{by(common)} ({which}; measured on {', '.join(counted)})"
    else:
        lag = ("lags the position (ms; negative: runs ahead of it): "
               + ", ".join(f"{j} {velocity[j] * 1e3:.3g}" for j in shifted))
    lowest = min(estimates[j].r for j in counted)
    head = (f"{series.source}: channel lag: the logged velocity {lag}: its cross-correlation with the position's "
            f"derivative peaks there (r ≥ {lowest:.4f}), in each half of the log and for their derivatives alike")
    if ratio is None:
        tail = "the effort cannot be judged (no joint's effort follows its motion well enough): left as logged"
    elif any(effort.values()):
        tail = (f"the effort shares the lag (a fit of it to the motion leaves {ratio:.2g} × the residual once "
                "shifted): moved back too")
    else:
        tail = (f"the effort shows no such lag (a fit of it to the motion leaves {ratio:.2g} × the residual once "
                "shifted): left as logged")
    return (f"{head}; the velocity moved back onto the position's stamps; {tail}; the {dropped} sample(s) this leaves "
            "without a value at the end of the log (of each segment) dropped")


def _effort_only(series: JointSeries, grid: _Grid | None = None) -> JointSeries:
    """A log without a logged velocity (or whose velocity is on time): ``series`` with its effort's own
    lag behind the position (:func:`_effort_scan`), where found, in ``meta`` as a candidate."""
    grid = _Grid(series) if grid is None else grid
    threshold = max(MIN_LAG_PERIODS * _period(series.t), MIN_LAG_S)
    candidate = _candidate_meta(_effort_scan(grid, threshold) if grid.ok else None)
    return _with_meta(series, {**series.meta, **candidate}) if candidate else series


def _candidate_meta(own: tuple[float, float, bool] | None) -> dict[str, float]:
    """The meta entries of an effort lag candidate (:func:`_effort_scan`'s (lag, ratio, confirmed)); {}: none."""
    if own is None:
        return {}
    return {CANDIDATE_KEY: own[0], CANDIDATE_RATIO_KEY: own[1], CANDIDATE_CONFIRMED_KEY: float(own[2])}


def effort_lag_candidate(series: JointSeries) -> tuple[float, float, bool] | None:
    """(lag s, residual ratio, confirmed by the motion) of the effort's own lag the loader found in
    ``series`` (the whole log and a half of it), or None."""
    if CANDIDATE_KEY not in series.meta:
        return None
    return (float(series.meta[CANDIDATE_KEY]), float(series.meta.get(CANDIDATE_RATIO_KEY, float("nan"))),
            bool(series.meta.get(CANDIDATE_CONFIRMED_KEY, 0.0)))


def shift_effort(series: JointSeries, lag: float | dict[str, float], why: str) -> tuple[JointSeries, str]:
    """(``series`` with its effort read ``lag`` s later (one for every joint, or {joint: s}; moved
    back onto the position's stamps, the samples left without a value dropped), recorded in its
    meta, the note saying so); ``why``: the evidence, after "the effort lags the position by …: "."""
    lags = {j: float(lag.get(j, 0.0)) for j in series.joints} if isinstance(lag, dict) \
        else dict.fromkeys(series.joints, float(lag))
    out, dropped = _shifted(series, dict.fromkeys(series.joints, 0.0), lags)
    candidate = (CANDIDATE_KEY, CANDIDATE_RATIO_KEY, CANDIDATE_CONFIRMED_KEY)
    out.meta = {**{k: v for k, v in series.meta.items() if k not in candidate},
                **{f"{META_PREFIX}effort/{j}": v for j, v in lags.items()}}
    if len(set(lags.values())) == 1:
        common = next(iter(lags.values()))
        by = f"{'lags' if common > 0 else 'runs ahead of'} the position by {abs(common) * 1e3:.3g} ms (every joint)"
    else:
        by = "lags the position (ms; negative: runs ahead of it): " + ", ".join(
            f"{j} {v * 1e3:.3g}" for j, v in lags.items())
    return out, (f"{series.source}: channel lag: the effort {by}: {why}: moved back onto the position's stamps; the "
                 f"{dropped} sample(s) this leaves without a value at the end of the log (of each segment) dropped")


def _effort_scan(grid: _Grid, threshold: float) -> tuple[float, float, bool] | None:
    """(the lag of the effort behind the position (s), the residual ratio there) when a shift of it
    explains it better by the motion than as logged: each moving joint's effort (whose motion
    explains it: EFFORT_FIT_SHARE) regressed on the motion as :func:`_effort_ratio` does (and on the
    sines and cosines of sums of consecutive moving joints), at every
    shift of the analysis grid within ±MAX_LAG_S (and MAX_LAG_SHARE of the segment); the shift that
    minimises the geometric mean over the joints of residual(shift) / residual(0) is found when each
    half of the log finds the same shift (within LAG_TOLERANCE_PERIODS analysis periods or
    LAG_TOLERANCE_SHARE) and the shift is at least MIN_LAG_S: (lag, that mean, confirmed: the mean at
    most EFFORT_SCAN_RATIO, the shift at least ``threshold`` and both halves agreeing); found by the
    whole log and one half only (the other's motion may tell little of its timing: a UR5 lagged 20 ms,
    the halves 20 and 12.8 ms at 86 Hz), a candidate; found by both halves alike but not by the whole
    (a Panda lagged 8.6 ms at 2.4 kHz: 5.9 ms in each half, 3.8 ms over the whole, the regression short
    of its coupling), their mean a candidate; None otherwise. A lag of the effort
    shows in the Coulomb step at every reversal; the regression is not the system's model, whose
    misfit can hide a lag the halves agree on (a one-joint Stribeck law lagged 2 ms: 0.985; a 6-DOF
    arm's 7.5 ms: 0.96)."""
    n = grid.q.shape[0]
    search = int(min(MAX_LAG_S, MAX_LAG_SHARE * grid.n * grid.dt) / grid.step)
    if not grid.moving.any() or search < 2 or n < 16 * search:
        return None
    whole = _scan(grid, 0, n, search)
    if whole is None:
        return None
    lag, ratio = whole
    if ratio >= 1.0 or abs(lag) < MIN_LAG_S:
        return None
    tolerance = _tolerance(lag, grid.step)
    halves = [_scan(grid, a, b, search) for a, b in ((0, n // 2), (n // 2, n))]
    agree = [h is not None and abs(h[0] - lag) <= tolerance for h in halves]
    if not any(agree):
        if None in halves:
            return None
        (first, r1), (second, r2) = halves
        both = 0.5 * (first + second)
        if abs(first - second) > _tolerance(both, grid.step) or abs(both) < MIN_LAG_S or max(r1, r2) >= 1.0:
            return None
        return both, float(np.sqrt(r1 * r2)), False  # the halves agree, the whole not: a candidate only
    return lag, ratio, all(agree) and ratio <= EFFORT_SCAN_RATIO and abs(lag) >= threshold


def _scan(grid: _Grid, a: int, b: int, search: int) -> tuple[float, float] | None:
    """(the shift (s) of the effort rows a..b of ``grid`` that its motion explains best, the
    geometric mean over the judged joints of residual(shift) / residual(0) there), or None (no
    joint judged, or the least at the edge of the search)."""
    moving = np.flatnonzero(grid.moving)
    n = b - a
    inner = slice(a + search, b - search)
    size = n - 2 * search
    logs = []
    q = grid.q[inner][:, moving]
    # the gravity of a serial arm: sines and cosines of each joint and of the sums of 2 and 3 in a row
    m = q.shape[1]
    angles = np.column_stack([q] + [sum(q[:, i : m - k + i] for i in range(k + 1)) for k in (1, 2) if m > k])
    for j in moving:
        columns = _motion_columns(grid, inner, moving, j, angles)
        basis, _ = np.linalg.qr(columns)
        y = grid.effort[a:b, j] - grid.effort[a:b, j].mean()
        sums = np.concatenate(([0.0], np.cumsum(y * y)))
        energy = sums[size:] - sums[:-size]  # ‖y_s‖² of each window (2·search + 1 shifts)
        projected = sum(signal.correlate(y, basis[:, c], mode="valid", method="fft") ** 2
                        for c in range(basis.shape[1]))
        residual = np.maximum(energy - projected, 1e-300)
        total = np.concatenate(([0.0], np.cumsum(y)))
        spread = energy - (total[size:] - total[:-size]) ** 2 / size
        best = int(np.argmin(residual))
        if not (spread > 0).all() or residual[best] / spread[best] > EFFORT_FIT_SHARE:
            continue  # the motion does not explain this effort: not judged
        logs.append(np.log(residual / residual[search]))
    if not logs:
        return None
    mean = np.mean(logs, axis=0)
    k = int(np.argmin(mean))
    if k in (0, mean.size - 1):
        return None
    curve = mean[k - 1] - 2 * mean[k] + mean[k + 1]
    shift = 0.5 * (mean[k - 1] - mean[k + 1]) / curve if curve > 0 else 0.0
    return (k - search + shift) * grid.step, float(np.exp(mean[k]))


def _motion_columns(grid: _Grid, rows: slice, moving: np.ndarray, j: int, angles: np.ndarray) -> np.ndarray:
    """The motion an effort of joint ``j`` is regressed on, at ``rows`` of ``grid``: q̈ of the
    ``moving`` joints, q̇ and sign q̇ of joint j, 1, and the sines and cosines of ``angles``."""
    qd = grid.qd[rows, j]
    return np.column_stack([grid.qdd[rows][:, moving], qd, np.sign(qd), np.ones(qd.size), np.sin(angles),
                            np.cos(angles)])


def _filtered_note(series: JointSeries, filtered: dict, head: bool = True) -> str:
    joints = ", ".join(f"{j} (its level {e.lag * 1e3:.3g} ms, its changes {e.shape_lag * 1e3:.3g} ms)"
                       for j, e in filtered.items())
    text = (f"the logged velocity of {joints} lags the position by no single delay (filtered inside the drive?): "
            "left as logged")
    return f"{series.source}: channel lag: {text}" if head else text


def _period(t: np.ndarray) -> float:
    return float(np.median(np.diff(t)))


def _tolerance(lag: float, period: float) -> float:
    return max(LAG_TOLERANCE_PERIODS * period, LAG_TOLERANCE_SHARE * abs(lag))


def _with_meta(series: JointSeries, meta: dict) -> JointSeries:
    return JointSeries(series.t, list(series.joints), series.position, series.effort, series.velocity,
                       series.source, dict(series.extras), meta, list(series.notes))


class _Grid:
    """The longest segment of a series on uniform stamps, low-passed (zero-phase) and kept at about
    ANALYSIS_RATE_HZ: position, its derivative and second derivative, the velocity and the effort."""

    def __init__(self, series: JointSeries):
        a, b = max(series.segment_bounds(), key=lambda ab: ab[1] - ab[0])
        t = series.t[a:b]
        self.n = b - a
        self.dt = _period(t)
        if self.n < MIN_SEGMENT_SAMPLES or not self.dt > 0:
            self.ok = False
            return
        self.ok = True
        fs = 1.0 / self.dt
        grid = t[0] + self.dt * np.arange(int(np.floor((t[-1] - t[0]) / self.dt)) + 1)

        def uniform(x: np.ndarray) -> np.ndarray:
            return np.column_stack([np.interp(grid, t, x[a:b, j]) for j in range(x.shape[1])])

        q = uniform(series.position)
        # position noise σ from the second differences (6σ² for white noise, the motion's share negligible)
        noise = 1.4826 * np.median(np.abs(np.diff(q, 2, axis=0)), axis=0) / np.sqrt(6.0)
        self.moving = np.ptp(q, axis=0) > MOVING_FACTOR * noise
        self.cutoff = min(LAG_CUTOFF_SHARE * fs, LAG_CUTOFF_HZ)
        sos = signal.butter(LAG_ORDER, self.cutoff, fs=fs, output="sos")
        keep = max(1, int(fs // ANALYSIS_RATE_HZ))
        smooth = lambda x: signal.sosfiltfilt(sos, x, axis=0)[::keep]
        self.step = self.dt * keep
        qf = signal.sosfiltfilt(sos, q, axis=0)
        qd = np.gradient(qf, self.dt, axis=0)
        self.q, self.qd = qf[::keep], qd[::keep]
        self.qdd = np.gradient(qd, self.dt, axis=0)[::keep]
        self.velocity = None if series.velocity is None else smooth(uniform(series.velocity))
        self.effort = smooth(uniform(series.effort))


def _velocity_estimates(series: JointSeries, grid: _Grid) -> dict[str, _Estimate]:
    """{joint: estimate} of the moving joints (``grid``: the signals of ``series``), low-passed
    signals without their ends (EDGE_PERIODS of the cut-off: filter transients); empty when the
    log is too short to judge.

    A pure delay shifts every frequency alike: the velocities and their derivatives give the same
    lag; velocities estimated otherwise (another filter) differ in phase between the motion and its
    changes, and a smooth motion (a ramp) leaves the peak ill-defined: the halves disagree."""
    if not grid.ok:
        return {}
    search = int(min(MAX_LAG_S, MAX_LAG_SHARE * grid.n * grid.dt) / grid.step)
    trim = int(np.ceil(EDGE_PERIODS / grid.cutoff / grid.step))
    inner = slice(trim, grid.qd.shape[0] - trim)
    velocity, qd = grid.velocity[inner], grid.qd[inner]
    if search < 2 or qd.shape[0] < 8 * search:
        return {}
    acceleration, qdd = np.gradient(velocity, axis=0), np.gradient(qd, axis=0)
    half = qd.shape[0] // 2
    out = {}
    for j, joint in enumerate(series.joints):
        if not grid.moving[j]:
            continue
        whole = _peak(velocity[:, j], qd[:, j], search)
        if whole is None:
            continue
        lag = whole[0] * grid.step
        halves = [_peak(velocity[s, j], qd[s, j], min(search, half // 4)) for s in (slice(0, half), slice(half, None))]
        shape = _peak(acceleration[:, j], qdd[:, j], search)
        out[joint] = _Estimate(lag, whole[1], all(h is not None and abs(h[0] * grid.step - lag) <= _tolerance(
            lag, grid.dt) for h in halves), None if shape is None else shape[0] * grid.step,
                               0.0 if shape is None else shape[1])
    return out


def _peak(x: np.ndarray, y: np.ndarray, search: int) -> tuple[float, float] | None:
    """(lag of ``x`` behind ``y`` in samples, their correlation there) at the peak of their
    correlation within ±``search`` samples: the same samples of ``y`` (all but ``search`` at either
    end) against each shifted window of ``x``, each correlation normalised by its own window (no bias
    from a shrinking overlap or from the energy of slow motion moving with the window); None without
    variance or without a peak inside."""
    if search < 1 or x.size <= 2 * search + 2:
        return None
    inner = y[search:y.size - search] - y[search:y.size - search].mean()
    size = inner.size
    c = signal.correlate(x, inner, mode="valid", method="fft")  # c[k]: x shifted by k − search
    def window_sums(z: np.ndarray) -> np.ndarray:
        total = np.concatenate(([0.0], np.cumsum(z)))
        return total[size:] - total[:-size]

    x = x - x.mean()  # the window sums of a centred x keep their digits
    mean = window_sums(x) / size
    spread = window_sums(x * x) - size * mean**2  # Σ(x − mean)² of each window
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = c / np.sqrt(spread * np.dot(inner, inner))
    if not np.isfinite(rho).all():
        return None
    k = int(np.argmax(rho))
    if k == 0 or k == rho.size - 1:
        return None  # at the edge of the search: no peak inside
    curve = rho[k - 1] - 2 * rho[k] + rho[k + 1]
    shift = 0.5 * (rho[k - 1] - rho[k + 1]) / curve if curve < 0 else 0.0
    return float(k - search + shift), float(rho[k])


def _effort_ratio(series: JointSeries, grid: _Grid, velocity: dict[str, float]) -> float | None:
    """The geometric mean over the moving joints (whose effort the motion explains) of the residual
    of the effort regressed on the motion, shifted by the joint's velocity lag over as logged; None
    when no joint's effort can be judged (``grid``: the signals of ``series``)."""
    moving = np.flatnonzero(grid.moving)
    if moving.size == 0:
        return None
    n = grid.q.shape[0]
    t = np.arange(n) * grid.step
    ratios = []
    for j in moving:
        lag = velocity[series.joints[j]]
        if not lag:
            continue
        inside = (t + lag >= 0) & (t + lag <= t[-1])
        columns = _motion_columns(grid, slice(None), moving, j, grid.q[:, moving])[inside]
        residual = []
        for shift in (0.0, lag):
            y = np.interp(t[inside] + shift, t, grid.effort[:, j])
            spread = np.sum((y - y.mean()) ** 2)
            if not spread > 0:
                break
            coef, *_ = np.linalg.lstsq(columns, y, rcond=None)
            residual.append(np.sum((y - columns @ coef) ** 2) / spread)
        if len(residual) == 2 and min(residual) <= EFFORT_FIT_SHARE and residual[0] > 0:
            ratios.append(residual[1] / residual[0])
    return float(np.exp(np.mean(np.log(ratios)))) if ratios else None


def _shifted(series: JointSeries, velocity: dict[str, float], effort: dict[str, float]) -> tuple[JointSeries, int]:
    """(``series`` with each joint's velocity and effort read at t + its lag within each segment,
    without the samples left without a value, how many were dropped)."""
    v = None if series.velocity is None else series.velocity.copy()
    e = series.effort.copy()
    valid = np.ones(len(series), dtype=bool)
    for a, b in series.segment_bounds():
        t = series.t[a:b]
        for j, joint in enumerate(series.joints):
            for out, source, lag in ((v, series.velocity, velocity[joint]), (e, series.effort, effort[joint])):
                if lag and out is not None:
                    out[a:b, j] = np.interp(t + lag, t, source[a:b, j])
                    valid[a:b] &= (t + lag >= t[0]) & (t + lag <= t[-1])
    shifted = JointSeries(series.t, list(series.joints), series.position, e, v, series.source, dict(series.extras),
                          dict(series.meta), list(series.notes))
    return shifted.take(np.flatnonzero(valid)), int(np.count_nonzero(~valid))
