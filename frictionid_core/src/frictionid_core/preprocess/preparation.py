"""From a log to the prepared signals: resampling of irregular stamps, filtering and
differentiation (:func:`prepare`), the rates of the regressor columns and of friction dips, and
:func:`preprocess` (the rule, then the preparation)."""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.preprocess.filters import (
    central_difference,
    decimation_indices,
    lowpass_position,
)
from frictionid_core.preprocess.lag import lag_record
from frictionid_core.preprocess.rule import (
    _per_joint,
    choose_preprocessing,
    clean_acceleration_cutoff,
    differentiated_noise_var,
    recorded_velocity,
)
from frictionid_core.preprocess.settings import (
    DIP_CUTOFF_FACTOR,
    DIP_FACTOR,
    DIP_WINDOW,
    JITTER_TOLERANCE,
    MAX_CUTOFF_SHARE,
    QDD_NOISE_SHARE_LIMIT,
    SMOOTH_RATE_PER_CUTOFF,
    THIN_MARGIN,
    Prepared,
    Preprocessing,
    TooFewSamples,
    cutoff_range,
    joint_cutoffs,
)
from frictionid_core.timeseries import JointSeries


def resample_uniform(series: JointSeries) -> JointSeries:
    """Return ``series`` on a uniform grid if its stamps jitter (linear interpolation).

    The grid keeps the mean period and the first and last stamps; a note says so and how many
    stamps were off.
    """
    dt = series.dt
    off = int(np.count_nonzero(np.abs(np.diff(series.t) - dt) > JITTER_TOLERANCE * dt))
    if not off:
        return series
    t = series.t[0] + dt * np.arange(len(series))
    interp = lambda a: None if a is None else np.column_stack(
        [np.interp(t, series.t, a[:, j]) for j in range(a.shape[1])])
    out = JointSeries(t, list(series.joints), interp(series.position), interp(series.effort),
                      interp(series.velocity), series.source,
                      {k: np.interp(t, series.t, v) if v.ndim == 1 else interp(v) for k, v in series.extras.items()},
                      dict(series.meta), list(series.notes))
    out.notes.append(f"{series.source}: {off} of {len(series) - 1} stamp intervals jittered by more than "
                     f"{JITTER_TOLERANCE:.0%} of the mean period: all {len(series)} samples resampled onto a "
                     f"uniform {1 / dt:.6g} Hz grid (linear interpolation)")
    return out


def prepare(series: JointSeries, settings: Preprocessing, dt: float | None = None) -> Prepared:
    """Filter, differentiate and trim ``series`` (uniform stamps; no decimation yet) with
    resolved ``settings``.

    Velocity and acceleration are central differences of the filtered position, or of the
    recorded velocity low-passed the same way (``settings.velocity``). ``dt`` overrides the
    sample period (default: the mean stamp spacing).
    """
    if not settings.resolved:
        raise FrictionIdError("prepare needs resolved settings (see choose_preprocessing)")
    dt = series.dt if dt is None else dt
    fs = 1.0 / dt

    cutoffs = joint_cutoffs(settings.cutoff_hz, list(series.joints))

    def smooth(x: np.ndarray) -> np.ndarray:
        return x if settings.filter == "none" else lowpass_position(x, fs, cutoffs, settings.order)

    q = smooth(series.position)
    if settings.velocity == "recorded":
        qd = smooth(recorded_velocity(series))
    else:
        qd = central_difference(q, dt)
    qdd = central_difference(qd, dt)
    n = len(series)
    start, end = (int(round(s * fs)) for s in (settings.trim_start_s, settings.trim_end_s))
    stop = n - end
    if stop - start < 3:
        raise TooFewSamples(f"{series.source}: {n} samples ({(n - 1) * dt:.4g} s) leave nothing after trimming "
                         f"{settings.trim_start_s:g} s + {settings.trim_end_s:g} s")
    sl = slice(start, stop)
    return Prepared(series.t[sl], q[sl], qd[sl], qdd[sl], series.effort[sl], dt)


def dip_needs(fs: float, reversal_acceleration: float, speed_scale: float) -> tuple[int, float]:
    """(largest decimation, smallest cut-off in Hz) for a friction dip of speed scale
    ``speed_scale`` (vs) crossed at reversals at ``reversal_acceleration`` (a).

    The dip lasts about 2·vs/a there: a pulse of bandwidth f = a/(π·vs). It is evaluated at the
    decimated velocity while the torque is anti-aliased, so the anti-alias band 0.4·fs/n must
    keep DIP_FACTOR·f; and the position filter must keep f/DIP_CUTOFF_FACTOR, or the filtered
    velocity misplaces the dip (both calibrated on the synthetic TX40 recordings: vs and δ within
    5 %; coarser choices bias δ by 10–70 %, f/6 by 5 % on the six-joint bag's joint 2)."""
    if reversal_acceleration <= 0 or speed_scale <= 0:
        return np.iinfo(np.int32).max, 0.0
    f = reversal_acceleration / (np.pi * speed_scale)
    return max(1, int(np.floor(0.4 * fs / (DIP_FACTOR * f)))), min(f / DIP_CUTOFF_FACTOR, MAX_CUTOFF_SHARE * fs)


def thinned_rows(qd: np.ndarray, qdd: np.ndarray, fs: float, settings: Preprocessing, joints: list[str]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The analysis rows ``settings.thin`` keeps, from the velocity and acceleration (Nd, J) of
    the row joints ``joints`` at the analysis instants (sample rate ``fs`` before decimation):
    (indices (M,), weights (M,), decimation of each row (M,)).

    Each instant gets the coarsest decimation L (a multiple of ``decimate`` dividing ``decimate
    × thin``) that the :func:`dip_needs` rule allows, THIN_MARGIN times over, for the dips of
    ``dip_scale`` it is in (|q̇| < DIP_WINDOW × vs, crossed at its |q̈|), the finest within
    ``thin`` analysis rows either side; ``decimate × thin`` outside dips. (The rule's
    calibration held for rows mostly well inside it; every row at its limit biases δ of the
    slowest dips by a few %: TX40 joint 1, vs 0.025, −4 %; margin 2: −1.5 %.) A row is kept on its decimation's grid
    (aligned to the last instant as :func:`decimation_indices`) and comes from that decimation,
    whose own anti-alias filter low-passes the noise its skipped rows would have averaged. A
    row's weight is √(analysis rows up to the next kept one), so the weighted cost sums over
    time as if every row were kept."""
    nd = qd.shape[0]
    n = settings.decimate
    if settings.thin <= 1:
        return np.arange(nd), np.ones(nd), np.full(nd, n)
    coarse = n * settings.thin
    levels = [k * n for k in range(1, settings.thin + 1) if settings.thin % k == 0]
    need = np.full(nd, float(coarse))
    for j, joint in enumerate(joints):
        vs = (settings.dip_scale or {}).get(joint)
        if vs:
            # dip_needs(fs, |q̈|, vs)[0] at each instant, with the margin: ⌊0.4·fs / (m·DIP_FACTOR·|q̈|/(π·vs))⌋
            with np.errstate(divide="ignore"):
                allowed = np.floor(0.4 * fs * np.pi * vs / (THIN_MARGIN * DIP_FACTOR * np.abs(qdd[:, j])))
            need = np.where(np.abs(qd[:, j]) < DIP_WINDOW * vs, np.minimum(need, allowed), need)
    level = np.full(nd, coarse)
    window = np.ones(2 * settings.thin + 1)
    for L, coarser in reversed(list(zip(levels[:-1], levels[1:]))):  # a finer need within ± thin rows wins
        level[np.convolve((need < coarser).astype(float), window, mode="same") > 0] = L
    step = level // n
    index = np.flatnonzero((nd - 1 - np.arange(nd)) % step == 0)
    return index, np.sqrt(np.diff(index, append=nd).astype(float)), level[index]


def column_stride(fs: float, settings: Preprocessing) -> int:
    """The largest divisor k of the decimation with fs/k ≥ SMOOTH_RATE_PER_CUTOFF × the cut-off
    (1 without a position filter): a column that is a smooth function of the filtered q, q̇,
    q̈ (a robot regressor's) is computed on every k-th sample only and anti-aliased at that
    rate (:func:`decimate` with ``stride``), its band kept; above 50 × the cut-off the
    order-4 forward–backward Butterworth has attenuated q by (1/50)⁸ ≈ 3e-14. What remains
    differs from full-rate filtering by ~1e-4 of a column in the first and last rows (the
    filters' edge transients) and less inside."""
    if settings.filter == "none":
        return 1
    n = settings.decimate
    highest = cutoff_range(settings.cutoff_hz)[1]
    return max(k for k in range(1, n + 1) if n % k == 0 and (k == 1 or fs / k >= SMOOTH_RATE_PER_CUTOFF * highest))


def subsample(prepared: Prepared, stride: int) -> Prepared:
    """Every ``stride``-th sample of ``prepared``, aligned to the last (:func:`decimation_indices`)."""
    if stride == 1:
        return prepared
    k = decimation_indices(prepared.t.size, stride)
    return Prepared(prepared.t[k], prepared.q[k], prepared.qd[k], prepared.qdd[k], prepared.tau[k],
                    prepared.dt * stride)


def reversal_acceleration(prepared: Prepared) -> np.ndarray:
    """(J,) the largest |q̈| where q̇ changes sign (0 without reversal): how fast the velocity
    crosses a friction law's low-speed dip."""
    out = np.zeros(prepared.qd.shape[1])
    for j in range(out.size):
        flips = np.flatnonzero(np.diff(np.sign(prepared.qd[:, j])) != 0)
        if flips.size:
            out[j] = np.abs(prepared.qdd[flips, j]).max()
    return out


def preprocess(series: JointSeries, requested: Preprocessing | None = None
               ) -> tuple[Prepared, Preprocessing, dict, list[str]]:
    """Resample jittered stamps, choose the unset settings, filter, differentiate and trim.

    Returns the prepared signals, the resolved settings, the report of
    :func:`choose_preprocessing` with the q̈ noise share per joint (``qdd_noise_share``: the
    share of the filtered q̈ variance that is differentiated position noise) and the channel lags
    the loader removed (``lag_s``: :func:`~frictionid_core.preprocess.lag.lag_record`), and the
    notes of what was done to the stamps.
    """
    order = (requested or Preprocessing()).order
    if len(series) <= 3 * order:  # before any estimate from the data (a periodogram, a gradient)
        raise TooFewSamples(f"{len(series)} samples are too few for the order-{order} Butterworth filter (needs more "
                            f"than {3 * order})")
    uniform = resample_uniform(series)
    notes = uniform.notes[len(series.notes):]
    settings, report = choose_preprocessing(uniform, requested)
    prepared = prepare(uniform, settings)
    n0, differences = report.pop("_qdd_noise")
    fs = 1.0 / prepared.dt
    joints = list(series.joints)
    filtered = None if settings.filter == "none" else joint_cutoffs(settings.cutoff_hz, joints)
    noise = differentiated_noise_var(n0, fs, filtered, settings.order, differences)
    var = np.var(prepared.qdd, axis=0)
    share = np.where(var > 0, noise / np.where(var > 0, var, 1.0), np.nan)
    report["qdd_noise_share"] = _per_joint(joints, share)
    # the cut-off a noise-dominated acceleration needs (named by the warning)
    noisy = [j for j, s in enumerate(share) if joints[j] in report["moving_joints"] and s > QDD_NOISE_SHARE_LIMIT]
    clean = np.full(len(joints), np.nan)
    if noisy and settings.filter != "none":
        signal_of = recorded_velocity(uniform) if settings.velocity == "recorded" else uniform.position
        clean[noisy] = clean_acceleration_cutoff(signal_of[:, noisy], fs, n0[noisy], settings.order, differences)
    report["qdd_clean_cutoff_hz"] = {joints[j]: (float(clean[j]) if np.isfinite(clean[j]) else None) for j in noisy}
    report["reversal_acceleration"] = _per_joint(list(series.joints), reversal_acceleration(prepared))
    report["resampled_samples"] = len(series) if notes else 0
    report["lag_s"] = lag_record(series)  # the channel lag the loader's checks removed
    return prepared, settings, report, notes
