"""The rule choosing the pre-processing from the data (:func:`choose_preprocessing`).

Zero-phase Butterworth on position, central differences for velocity and acceleration,
edge trimming, and parallel decimation (low-pass + keep 1 of n) of every observation column
and of the torque. Irregular stamps are first resampled onto a uniform grid.

Settings left unset (None) are chosen from the data by :func:`choose_preprocessing`; the
identification then takes, per joint, the cut-off that predicts the effort best among these and
lower ones (blocked cross-validation: :mod:`frictionid_core.identification.cross_validation`):

* position-noise density N0 of each joint: median periodogram of q over [0.25, 0.45]·fs / ln 2
  (white noise; the median of a χ²₂/2 bin is ln 2 × its mean); σ_q = sqrt(N0·fs/2);
* a joint *moves* when its range exceeds 100·σ_q;
* motion bandwidth B of each joint (reported): the largest frequency below which 99 % of its q̇
  power lies, after the differentiated position noise (fs·sin(2πf/fs))²·N0 is removed;
* cut-off fc of each moving joint, in two steps:

  1. its highest useful cut-off: the one that minimises the mean-square error of its filtered
     acceleration, estimated without bias from the periodogram P(f) of its position (a Stein-type
     risk): Σ_f (fs·sin(2πf/fs))⁴·[(P − N0)·(1 − A)² + N0·A²], A(f) = 1/(1 + (f/fc)^(2·order)) the
     forward–backward Butterworth's gain, over fc from 4 periodogram bins to 0.2·fs: above it the
     position holds more noise than motion;
  2. between 10·B (where B lies below that bound: a band above it is noise, not motion) and that
     bound, the cut-off whose filtered signals best predict the joint's effort: the least-squares
     residual of its effort on every joint's q̈, q̇, sign(q̇) and a constant, over the interval's
     lower end and the cut-offs of a fixed logarithmic grid inside it (CUTOFFS_PER_DECADE: 1,
     1.47, 2.15, 3.16, 4.64, 6.81, 10, … Hz, the same whatever the interval, so records of one
     motion choose alike): the lowest within 1 % of the least residual (a higher one only where it
     predicts clearly better; the residuals of nearby cut-offs differ by less than that). A
     position spectrum can stand above its noise for motion the effort does not show (a real
     5 kHz motor encoder's vibrations: a cut-off at the position's bound predicted the TX40's
     validation torque with 49 % error, 17 % at 10·B), and stick/slip transitions show in both;

  a moving joint without a credible bandwidth (B at or above that bound: a ramp, whose q̇ holds no
  motion above the noise) takes the lowest cut-off of the joints that have one (given or chosen
  on a credible bandwidth), at most its own bound (its bound where no joint has one) — its
  bound would otherwise set the decimation to keep content no motion explains; a joint that does
  not move takes the lowest cut-off of the moving ones;
* decimation n = max(1, ⌊min(fs / (10·min fc), 0.4·fs / (1.5·max fc))⌋): the analysis rate ≥ 10 ×
  the lowest cut-off (the anti-alias band 0.4·fs/n ≥ 4 × it), as one cut-off for every joint would
  have it, and the band ≥ 1.5 × the highest cut-off (where the forward–backward Butterworth keeps
  4 % of the motion), so every joint's filtered motion passes. A rate
  set by the highest cut-off admits effort content no joint's motion explains (the real TX40's
  5 kHz currents: validation 18.3 % at 714 Hz, 16.9 % at 333 Hz, same cut-offs); a friction
  dip's finer needs are met by the dip refit;
* trims 5/min fc s at both ends (the slowest pole of the order-4 Butterworth decays as
  e^(−2.4·fc·t): 6e-6 after 5/fc; 3/fc leaves 7e-4, which biases weakly determined base
  parameters), at most 10 % of the record each;
* slow-row threshold per joint: 10·σ_q̇, σ_q̇ the velocity noise that N0 leaves after the filter
  and the central difference (below it the sign of q̇ is noise), and at least 5e-4 × the joint's
  top speed (99th percentile of |q̇|): the few rows that close to a reversal otherwise let a
  Stribeck dip degenerate into a spike (vs at its lower bound) fitted to them;
* stick phases (``stick_speed``, set by the identification: see
  :mod:`frictionid_core.identification.stick`) are left out as the slow rows are, and counted apart;
  so are the rows within ``reversal_periods`` / fc of a joint's reversal (set by the identification
  of a law without a dip: the filter spreads a stick or slip there).

Both filters run as second-order sections, which stay exact at the small cut-off ratios and
large decimation factors the rule picks (the b/a form is off by 1e-3 at fc/Nyquist 4e-4 and
by 6 % at decimation by 60); on the EMPS benchmark they give its figures to every printed digit.
"""
from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
from scipy import signal

from frictionid_core.errors import InputError
from frictionid_core.preprocess.filters import (
    central_difference,
    lowpass_position,
)
from frictionid_core.preprocess.settings import (
    _GRID,
    ALIAS_BAND_PER_CUTOFF,
    ALIAS_BAND_SHARE,
    ANALYSIS_PER_CUTOFF,
    BANDWIDTH_SHARE,
    CUTOFF_GRID,
    CUTOFF_PER_BANDWIDTH,
    CUTOFFS_PER_DECADE,
    MAX_CUTOFF_SHARE,
    MAX_TRIM_SHARE,
    MIN_CUTOFF_BINS,
    MIN_SPEED_SHARE,
    MIN_SPEED_SIGMAS,
    MOVING_FACTOR,
    NOISE_BAND,
    PREDICTION_ROWS,
    PREDICTION_TOLERANCE,
    QDD_NOISE_SHARE_LIMIT,
    TRIM_PERIODS,
    Preprocessing,
    cutoff_range,
    joint_cutoffs,
)
from frictionid_core.timeseries import JointSeries


def linear_detrend(x: np.ndarray) -> np.ndarray:
    """``x`` (N, …) less its least-squares line along the first axis (scipy's ``detrend="linear"``
    of a periodogram over axis 0 in closed form: its general least-squares solve took half the time
    of a 30 000 × 6 periodogram)."""
    n = x.shape[0]
    t = np.arange(n, dtype=float) - (n - 1) / 2.0  # centred: the line's two columns are orthogonal
    mean = x.mean(axis=0)
    slope = np.tensordot(t, x, axes=(0, 0)) / (t @ t) if n > 1 else np.zeros_like(mean)
    return x - mean - np.multiply.outer(t, slope)


def noise_density(x: np.ndarray, fs: float) -> np.ndarray:
    """(J,) one-sided white-noise PSD level (unit²/Hz) of each column of x (N, J), from the
    median periodogram over NOISE_BAND·fs."""
    f, P = signal.periodogram(x, fs, window="hann", detrend=linear_detrend, axis=0)
    band = (f >= NOISE_BAND[0] * fs) & (f <= NOISE_BAND[1] * fs)
    if not band.any():
        return np.zeros(x.shape[1])
    return np.median(P[band], axis=0) / np.log(2)


def motion_bandwidth(q: np.ndarray, fs: float, n0: np.ndarray) -> np.ndarray:
    """(J,) frequency (Hz) below which BANDWIDTH_SHARE of each joint's motion q̇ power lies, the
    differentiated position noise (density ``n0``) removed; nan without motion above the noise."""
    f, P = signal.periodogram(central_difference(q, 1.0 / fs), fs, window="hann", detrend=linear_detrend, axis=0)
    P = np.clip(P - (fs * np.sin(2 * np.pi * f / fs))[:, None] ** 2 * n0[None], 0.0, None)
    c = np.cumsum(P, axis=0)
    out = np.full(q.shape[1], np.nan)
    for j in np.flatnonzero(c[-1] > 0):
        out[j] = f[np.searchsorted(c[:, j] / c[-1, j], BANDWIDTH_SHARE)]
    return out


def differentiated_noise_var(n0: np.ndarray, fs: float, cutoff_hz: float | np.ndarray | None, order: int,
                             differences: int) -> np.ndarray:
    """(J,) variance that white noise of density ``n0`` (J,) keeps after the forward–backward
    Butterworth at ``cutoff_hz`` (one value or (J,); none when None) and ``differences`` central
    differences: n0·∫₀^{fs/2} |H(f)|⁴·(fs·sin(2πf/fs))^(2·differences) df."""
    f = np.linspace(0.0, fs / 2, _GRID)[1:]
    gain = (fs * np.sin(2 * np.pi * f / fs)) ** (2 * differences)
    if cutoff_hz is None:
        return n0 * np.trapezoid(gain, f)
    cutoffs = np.broadcast_to(np.asarray(cutoff_hz, dtype=float), np.shape(n0))
    out = np.empty(np.shape(n0))
    for fc in np.unique(cutoffs):
        out[cutoffs == fc] = np.trapezoid(gain * butterworth_power(f, fs, fc, order) ** 2, f)
    return n0 * out


def butterworth_power(f: np.ndarray, fs: float, cutoff_hz: float | np.ndarray, order: int) -> np.ndarray:
    """|H(f)|² of scipy's digital Butterworth low-pass (``butter``: the bilinear transform with the
    cut-off prewarped), in closed form: 1/(1 + (tan(πf/fs)/tan(π·fc/fs))^(2·order)); ``cutoff_hz``
    may hold one value per row of a column ``f`` grid (broadcast)."""
    with np.errstate(over="ignore", divide="ignore"):
        ratio = np.tan(np.pi * np.minimum(f, fs / 2 * (1 - 1e-12)) / fs) / np.tan(np.pi * np.asarray(cutoff_hz) / fs)
        return 1.0 / (1.0 + ratio ** (2 * order))


def risk_cutoffs(q: np.ndarray, fs: float, n0: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Per column of q (N, J): (the cut-off in Hz that minimises the estimated mean-square error of
    the filtered acceleration, True where that is the highest cut-off allowed) — see the module doc.

    The periodogram's P − N0 is an unbiased estimate of the motion's spectrum, so the risk is
    too, bin by bin; its sum over thousands of bins varies little, and only its minimiser is used."""
    f, P = signal.periodogram(q, fs, window="hann", detrend=linear_detrend, axis=0)
    weight = (fs * np.sin(2 * np.pi * f / fs)) ** 4
    low, high = MIN_CUTOFF_BINS * fs / q.shape[0], MAX_CUTOFF_SHARE * fs
    grid = np.geomspace(low, high, CUTOFF_GRID) if low < high else np.array([high])
    motion = (P - n0[None]) * weight[:, None]  # (F, J)
    noise = n0[None] * weight[:, None]
    risk = np.empty((grid.size, q.shape[1]))
    for k, fc in enumerate(grid):
        gain = 1.0 / (1.0 + (f / fc) ** (2 * order))
        risk[k] = ((1.0 - gain) ** 2) @ motion + (gain**2) @ noise
    best = np.argmin(risk, axis=0)
    return grid[best], best == grid.size - 1


def rule_interval(q: np.ndarray, fs: float, n0: np.ndarray, bandwidth: np.ndarray, order: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per column of q (N, J) of noise density n0 and motion bandwidth (nan: not moving): (the
    lowest, the highest cut-off the rule allows in Hz, True where the highest lies at 0.2 × fs):
    10 × the bandwidth where it lies below the position's noise bound (:func:`risk_cutoffs`), and
    that bound (see the module doc)."""
    best, bound = risk_cutoffs(q, fs, n0, order)
    floor = np.where(bandwidth < best, CUTOFF_PER_BANDWIDTH * bandwidth, 0.0)
    floor = np.minimum(np.nan_to_num(floor), MAX_CUTOFF_SHARE * fs)
    return floor, np.maximum(best, floor), bound


def cutoff_grid(low: float, high: float) -> np.ndarray:
    """The cut-offs 10^(k / CUTOFFS_PER_DECADE) Hz in [low, high]."""
    first = np.ceil(CUTOFFS_PER_DECADE * np.log10(low) - 1e-9)
    last = np.floor(CUTOFFS_PER_DECADE * np.log10(high) + 1e-9)
    return 10.0 ** (np.arange(first, last + 1) / CUTOFFS_PER_DECADE)


def prediction_cutoffs(series: JointSeries, low: np.ndarray, high: np.ndarray, chosen: np.ndarray, order: int
                       ) -> np.ndarray:
    """(J,) per joint, the cut-off in [low, high] (Hz; ``high`` where the interval is empty) whose
    filtered signals best predict its effort (see the module doc: the lower ends and the fixed grid
    are tried); nan for joints not ``chosen``."""
    out = np.where(chosen, np.maximum(high, low), np.nan)
    open_ = chosen & (high > low * (1 + 1e-9)) & (low > 0)
    if not open_.any() or series.effort is None:
        return out
    fs = 1.0 / series.dt
    grid = np.unique(np.concatenate([low[open_], cutoff_grid(low[open_].min(), high[open_].max())]))
    n = len(series)
    trim = int(min(TRIM_PERIODS / grid[0], MAX_TRIM_SHARE * (n - 1) / fs) * fs)
    rows = np.arange(trim, n - trim, max(1, (n - 2 * trim) // PREDICTION_ROWS))
    if rows.size <= 4 * series.position.shape[1]:
        return out
    tau = series.effort[rows]
    residual = np.empty((grid.size, tau.shape[1]))
    for k, fc in enumerate(grid):
        q = lowpass_position(series.position, fs, fc, order)
        qd = central_difference(q, 1.0 / fs)
        qdd = central_difference(qd, 1.0 / fs)
        design = np.column_stack([qdd[rows], qd[rows], np.sign(qd[rows]), np.ones(rows.size)])
        coef, *_ = np.linalg.lstsq(design, tau, rcond=None)
        residual[k] = np.mean((tau - design @ coef) ** 2, axis=0)
    for j in np.flatnonzero(open_):
        inside = (grid >= low[j] * (1 - 1e-9)) & (grid <= high[j] * (1 + 1e-9))
        if inside.any():  # the lowest cut-off within PREDICTION_TOLERANCE of the best prediction
            r = residual[inside, j]
            out[j] = grid[inside][np.flatnonzero(r <= (1 + PREDICTION_TOLERANCE) * r.min())[0]]
        else:
            out[j] = high[j]
    return out


def clean_acceleration_cutoff(q: np.ndarray, fs: float, n0: np.ndarray, order: int, differences: int
                              ) -> np.ndarray:
    """(J,) the highest cut-off (Hz, on the risk grid; nan if none) at which the position noise
    makes up at most QDD_NOISE_SHARE_LIMIT of each column's filtered q̈ variance (q̈ after
    ``differences`` central differences of the filtered signal q (N, J) of noise density n0)."""

    f, P = signal.periodogram(q, fs, window="hann", detrend=linear_detrend, axis=0)
    weight = (fs * np.sin(2 * np.pi * f / fs)) ** (2 * differences)
    df = f[1] - f[0]
    grid = fs * _clean_grid(q.shape[0])
    total = ((1.0 / (1.0 + (f[None, :] / grid[:, None]) ** (2 * order))) ** 2 * weight) @ P * df  # (grid, J)
    noise_gain = fs ** (2 * differences + 1) * _unit_noise_gain(q.shape[0], order, differences)
    ok = n0[None, :] * noise_gain[:, None] <= QDD_NOISE_SHARE_LIMIT * total  # (grid, J)
    out = np.full(q.shape[1], np.nan)
    for k in range(grid.size):  # the highest cut-off of the grid that keeps the noise share
        out[ok[k]] = grid[k]
    return out


def _clean_grid(n: int) -> np.ndarray:
    """The cut-offs :func:`clean_acceleration_cutoff` tries on a log of ``n`` samples, in units of its rate."""
    return np.geomspace(MIN_CUTOFF_BINS / n, MAX_CUTOFF_SHARE, CUTOFF_GRID)


@functools.lru_cache(maxsize=64)
def _unit_noise_gain(n: int, order: int, differences: int) -> np.ndarray:
    """(CUTOFF_GRID,) the variance white noise of unit density keeps after the forward–backward
    Butterworth at each cut-off of :func:`_clean_grid` and ``differences`` central differences, at a
    rate of 1 (fs^(2·differences + 1) times it at fs): the same for every log of ``n`` samples (the
    pieces of the cross-validation's folds), so computed once."""
    u = np.linspace(0.0, 0.5, _GRID)[1:]
    gain = np.trapezoid(np.sin(2 * np.pi * u) ** (2 * differences)
                        * butterworth_power(u[None, :], 1.0, _clean_grid(n)[:, None], order) ** 2, u, axis=1)
    gain.flags.writeable = False
    return gain


# ---------------------------------------------------------------------- the rule
def choose_preprocessing(series: JointSeries, requested: Preprocessing | None = None
                         ) -> tuple[Preprocessing, dict]:
    """Resolve the unset settings of ``requested`` (default: all unset) from the data of
    ``series`` (uniform stamps) with the rule of the module doc.

    Returns the resolved settings (the cut-off as {joint: Hz}) and a JSON-ready report:
    sample_rate_hz, analysis_rate_hz, from_data (the settings chosen here), bandwidth_hz (and per
    joint), moving joints, position and velocity noise σ per joint, the joints whose risk minimum
    lies at the highest cut-off allowed (``cutoff_at_bound``), and what the q̈ noise statistic of
    :func:`preprocess` needs (``_qdd_noise``, not for JSON).
    """
    req = requested or Preprocessing()
    fs = 1.0 / series.dt
    joints = list(series.joints)
    given = req.cutoff_hz
    if isinstance(given, dict):
        unknown = [j for j in given if j not in joints]
        if unknown:
            raise InputError(f"{series.source}: cut-off given for joint(s) {unknown} not in the data (joints: "
                             f"{joints})")
    elif given is not None:
        given = dict.fromkeys(joints, float(given))
    high = [f"{v:g}" for v in (given or {}).values() if v >= fs / 2]
    if high:
        raise InputError(f"{series.source}: cut-off {high[0]} Hz at or above the Nyquist frequency "
                         f"{fs / 2:.6g} Hz of data sampled at {fs:.6g} Hz; give a lower one (--cutoff HZ)")
    n0 = noise_density(series.position, fs)
    sigma_q = np.sqrt(n0 * fs / 2)
    moving = np.ptp(series.position, axis=0) > MOVING_FACTOR * sigma_q
    bandwidth = np.where(moving, motion_bandwidth(series.position, fs, n0), np.nan)
    from_data = []
    cutoff = dict(given or {})
    at_bound, interval = [], {}
    if len(cutoff) < len(joints):  # the joints without a given cut-off: the rule
        if not np.any(np.isfinite(bandwidth)) and not cutoff:
            raise InputError(f"{series.source}: no joint moves more than {MOVING_FACTOR:g}× its position noise "
                             f"(σ_q {_per_joint(joints, sigma_q)}): the cut-off cannot be chosen from the data; "
                             "give one (--cutoff HZ)")
        if not np.nanmax(bandwidth, initial=0.0) > 0 and not cutoff:  # too short to show its motion's frequencies
            raise InputError(f"{series.source}: {len(series)} samples ({series.t[-1] - series.t[0]:.4g} s) show no "
                             "motion bandwidth: the cut-off cannot be chosen from the data; record longer motion or "
                             "give one (--cutoff HZ)")
        floor, ceiling, bound = rule_interval(series.position, fs, n0, bandwidth, req.order)
        interval = {j: [float(floor[k]), float(ceiling[k])] for k, j in enumerate(joints) if moving[k]}
        chosen = moving & np.array([j not in cutoff for j in joints])
        predicted = prediction_cutoffs(series, floor, ceiling, chosen, req.order)
        credible = chosen & (floor > 0)  # a joint whose motion bandwidth lies below its noise bound
        others = [*cutoff.values(), *predicted[credible]]
        for j, joint in enumerate(joints):
            if chosen[j]:
                cutoff[joint] = float(predicted[j])
                if not credible[j] and others:  # no credible bandwidth (a ramp): the others' lowest
                    cutoff[joint] = float(min(min(others), ceiling[j]))
                if bound[j]:
                    at_bound.append(joint)
        lowest = min(cutoff.values()) if cutoff else float(ceiling.min())
        cutoff.update({joint: lowest for joint in joints if joint not in cutoff})  # joints held still
        from_data.append("cutoff_hz")
    cutoff = {j: cutoff[j] for j in joints}
    low_cut = cutoff_range(cutoff)[0]
    dec = req.decimate
    if dec is None:
        dec = rule_decimation(fs, cutoff)
        from_data.append("decimate")
    trim = min(TRIM_PERIODS / low_cut, MAX_TRIM_SHARE * (series.t[-1] - series.t[0]))
    trims = {}
    for name in ("trim_start_s", "trim_end_s"):
        trims[name] = getattr(req, name)
        if trims[name] is None:
            trims[name] = trim
            from_data.append(name)
    filtered = None if req.filter == "none" else joint_cutoffs(cutoff, joints)
    if req.velocity == "recorded":
        n0_v, diffs = noise_density(recorded_velocity(series), fs), 0
    else:
        n0_v, diffs = n0, 1
    sigma_qd = np.sqrt(differentiated_noise_var(n0_v, fs, filtered, req.order, diffs))
    top_speed = np.percentile(np.abs(central_difference(series.position, 1.0 / fs)), 99, axis=0)
    min_speed = req.min_speed
    if min_speed is None:
        min_speed = dict(zip(joints, map(float, np.maximum(MIN_SPEED_SIGMAS * sigma_qd, MIN_SPEED_SHARE * top_speed))))
        from_data.append("min_speed")
    elif isinstance(min_speed, dict):
        missing = [j for j in joints if j not in min_speed]
        if missing:
            raise InputError(f"{series.source}: min_speed gives no value for joint(s) {missing} "
                             f"(given: {sorted(min_speed)})")
        min_speed = {j: float(min_speed[j]) for j in joints}
    else:
        min_speed = {j: float(min_speed) for j in joints}
    settings = replace(req, cutoff_hz=cutoff, decimate=dec, min_speed=min_speed, **trims)
    finite = bandwidth[np.isfinite(bandwidth)]
    report = {
        "sample_rate_hz": fs,
        "analysis_rate_hz": fs / dec,
        "chosen_from_data": bool(from_data),
        "from_data": from_data,
        "bandwidth_hz": float(finite.max()) if finite.size else None,
        "bandwidth_per_joint_hz": _per_joint(joints, bandwidth),
        "moving_joints": [j for j, m in zip(joints, moving) if m],
        "position_noise": _per_joint(joints, sigma_q),
        "velocity_noise": _per_joint(joints, sigma_qd),
        "top_speed": _per_joint(joints, top_speed),
        "cutoff_from_data": [j for j in joints if j not in (given or {})],
        "cutoff_at_bound": at_bound,
        "cutoff_interval_hz": interval,
        "record_s": float(series.t[-1] - series.t[0]),
        "_qdd_noise": (n0_v, diffs + 1),
    }
    return settings, report


def recorded_velocity(series: JointSeries) -> np.ndarray:
    """The logged velocity of ``series``; InputError naming the field when the log has none."""
    if series.velocity is None:
        raise InputError(f"{series.source}: no recorded velocity (field 'velocity') for --velocity recorded")
    return series.velocity


def _per_joint(joints: list[str], values: np.ndarray) -> dict[str, float | None]:
    return {j: (float(v) if np.isfinite(v) else None) for j, v in zip(joints, values)}


def rule_decimation(fs: float, cutoff_hz: float | dict[str, float]) -> int:
    """The decimation that keeps the analysis rate ≥ ANALYSIS_PER_CUTOFF × the lowest cut-off (one
    value or {joint: Hz}) and the anti-alias band ≥ ALIAS_BAND_PER_CUTOFF × the highest (see the
    module doc)."""
    low, high = cutoff_range(cutoff_hz)
    return max(1, int(np.floor(min(fs / (ANALYSIS_PER_CUTOFF * low),
                                   ALIAS_BAND_SHARE * fs / (ALIAS_BAND_PER_CUTOFF * high)))))
