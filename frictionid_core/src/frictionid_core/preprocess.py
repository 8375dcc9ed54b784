"""Signal preparation for inverse-dynamic identification (docs/reference.md#emps-idim-ls).

Zero-phase Butterworth on position, central differences for velocity and acceleration,
edge trimming, and parallel decimation (low-pass + keep 1 of n) of every observation column
and of the torque. Irregular stamps are first resampled onto a uniform grid.

Settings left unset (None) are chosen from the data by :func:`choose_preprocessing`:

* position-noise density N0 of each joint: median periodogram of q over [0.25, 0.45]·fs / ln 2
  (white noise; the median of a χ²₂/2 bin is ln 2 × its mean); σ_q = sqrt(N0·fs/2);
* a joint *moves* when its range exceeds 100·σ_q;
* motion bandwidth B: over the moving joints, the largest frequency below which 99 % of the
  q̇ power lies, after the differentiated position noise (fs·sin(2πf/fs))²·N0 is removed;
* cut-off fc = min(10·B, 0.2·fs); decimation n = max(1, ⌊fs / (10·fc)⌋) (analysis rate ≥ 10·fc,
  so the anti-alias band 0.4·fs/n stays ≥ 4·fc and the Stribeck dip, evaluated at the decimated
  velocity, keeps its shape); trims 5/fc s at both ends (the slowest pole of the order-4
  Butterworth decays as e^(−2.4·fc·t): 6e-6 after 5/fc; 3/fc leaves 7e-4, which biases weakly
  determined base parameters), at most 10 % of the record each;
* slow-row threshold per joint: 10·σ_q̇, σ_q̇ the velocity noise that N0 leaves after the filter
  and the central difference (below it the sign of q̇ is noise), and at least 5e-4 × the joint's
  top speed (99th percentile of |q̇|): the few rows that close to a reversal otherwise let a
  Stribeck dip degenerate into a spike (vs at its lower bound) fitted to them.

Both filters run as second-order sections, which stay exact at the small cut-off ratios and
large decimation factors the rule picks (the b/a form is off by 1e-3 at fc/Nyquist 4e-4 and
by 6 % at decimation by 60); on the EMPS benchmark they give its figures to every printed digit.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np
from scipy import signal

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.options import VELOCITY_SOURCES, check_choice
from frictionid_core.timeseries import JointSeries

# Stamps whose spacing deviates from the mean period by more than this fraction are
# treated as jittered and resampled onto a uniform grid.
JITTER_TOLERANCE = 0.05

# The rule (see the module doc).
NOISE_BAND = (0.25, 0.45)  # × fs: band where position records hold only noise
MOVING_FACTOR = 100.0  # a joint moves when its range exceeds this many σ_q
BANDWIDTH_SHARE = 0.99  # share of the motion's q̇ power below the bandwidth
CUTOFF_PER_BANDWIDTH = 10.0  # fc = this × bandwidth …
MAX_CUTOFF_SHARE = 0.2  # … at most this × fs (0.4 × Nyquist)
ANALYSIS_PER_CUTOFF = 10.0  # analysis rate ≥ this × fc
TRIM_PERIODS = 5.0  # trims of this many 1/fc at each end …
MAX_TRIM_SHARE = 0.1  # … at most this share of the record each
MIN_SPEED_SIGMAS = 10.0  # slow rows: |q̇| < max(this × σ_q̇, …
MIN_SPEED_SHARE = 5e-4  # … this × the joint's top speed)
DIP_FACTOR = 6.0  # friction dips: anti-alias band ≥ this × a/(π·vs), cut-off ≥ a/(π·vs) / this
DIP_WINDOW = 3.0  # a dip acts below this × vs (e^-3 of its height at δ = 1, e^-9 at δ = 2)
THIN_MARGIN = 2.0  # thinned rows near a dip: this × finer than the dip rule allows at that instant
SMOOTH_RATE_PER_CUTOFF = 100.0  # smooth columns (robot regressor) computed at ≥ this × the cut-off
_GRID = 20001  # frequency points of the noise integrals
_FILTER_COLUMNS = 16  # columns per block of the anti-alias filter

class TooFewSamples(InputError):
    """A signal shorter than a filter (or the trims) needs."""


FILTERS = ("butterworth", "none")  # zero-phase Butterworth on position | no position filter
METRIC_EFFORTS = ("recorded", "filtered")  # metrics against the recorded effort | the decimated filtered one


@dataclass(frozen=True)
class Preprocessing:
    """Settings of the identification pre-processing; None: chosen from the data.

    Attributes:
        cutoff_hz: Butterworth cut-off on position (and on a recorded velocity), Hz.
        order: Butterworth order (applied forward and backward).
        decimate: keep 1 sample of n after the anti-alias low-pass (1: no decimation).
        trim_start_s: seconds dropped at the start after differentiation (filter transients).
        trim_end_s: seconds dropped at the end.
        min_speed: rows whose decimated |q̇| is below this are left out (sign of q̇ unreliable at
            standstill and reversals): one value for every joint or {data joint: value}, rad/s
            or m/s; 0 keeps every row.
        velocity: ``position`` (central difference of the filtered position) or ``recorded``
            (the logged velocity, low-passed like the position; q̈ from it).
        filter: ``butterworth`` (zero-phase, second-order sections) or ``none`` (no position
            filter; the cut-off then only sets decimation and trims).
        metric: fit metrics against the ``recorded`` effort at the analysis instants, or the
            ``filtered`` (decimated) effort the fit uses (the EMPS benchmark's metric).
        thin: keep every analysis row only where a friction dip of ``dip_scale`` is crossed
            faster than the rate ``decimate × thin`` follows (:func:`thinned_rows`), one row in
            ``thin`` elsewhere, weighted so the cost stays an integral over time; metrics on
            one row in ``thin``. 1: every row.
        dip_scale: {row joint: speed scale vs (rad/s or m/s)} of the dips ``thin`` follows (set
            by the dip refit of an identification).
    """

    cutoff_hz: float | None = None
    order: int = 4
    decimate: int | None = None
    trim_start_s: float | None = None
    trim_end_s: float | None = None
    min_speed: float | dict[str, float] | None = None
    velocity: str = "position"
    filter: str = "butterworth"
    metric: str = "recorded"
    thin: int = 1
    dip_scale: dict[str, float] | None = None

    def __post_init__(self) -> None:
        for name, value, choices in (("velocity", self.velocity, VELOCITY_SOURCES),
                                     ("filter", self.filter, FILTERS), ("metric", self.metric, METRIC_EFFORTS)):
            check_choice(f"pre-processing {name}", value, choices, name)
        speeds = self.min_speed.values() if isinstance(self.min_speed, dict) else [self.min_speed]
        # (name, value, lowest allowed, allowed itself)
        limits = [("cutoff_hz", self.cutoff_hz, 0, False), ("order", self.order, 1, True),
                  ("decimate", self.decimate, 1, True), ("thin", self.thin, 1, True),
                  ("trim_start_s", self.trim_start_s, 0, True), ("trim_end_s", self.trim_end_s, 0, True),
                  *(("min_speed", v, 0, True) for v in speeds)]
        bad = [f"{name} {value}" for name, value, low, inclusive in limits
               if value is not None and (value < low or (value == low and not inclusive))]
        if bad:
            raise FrictionIdError(f"pre-processing: invalid {', '.join(bad)} (cut-off > 0, order, decimate and thin "
                                  "≥ 1, trims and min speed ≥ 0)")

    @property
    def resolved(self) -> bool:
        """True when no setting is left to choose from the data."""
        return None not in (self.cutoff_hz, self.decimate, self.trim_start_s, self.trim_end_s, self.min_speed)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict, rate_hz: float | None = None) -> Preprocessing:
        """The settings of a result's ``preprocessing`` block (its other keys are the report).

        Results written before the trims were in seconds hold ``trim_start``/``trim_end`` in
        samples (converted with ``rate_hz``) and kept every row, metrics on the filtered effort.
        """
        names = {f.name for f in fields(cls)}
        values = {k: v for k, v in d.items() if k in names}
        if "trim_start" in d and "trim_start_s" not in d:
            if rate_hz is None:
                raise FrictionIdError("pre-processing with trims in samples needs the sample rate")
            values.update(trim_start_s=d["trim_start"] / rate_hz, trim_end_s=d.get("trim_end", 0) / rate_hz,
                          metric="filtered", min_speed=values.get("min_speed", 0.0))
        return cls(**values)


@dataclass
class Prepared:
    """Filtered, differentiated, trimmed signals at full rate: each (N, J)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    dt: float


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


# ------------------------------------------------------------------------ filters
def lowpass_position(q: np.ndarray, fs: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth (forward–backward) of each column of q (N, J)."""
    if not 0.0 < cutoff_hz < fs / 2:
        raise InputError(f"filter cut-off {cutoff_hz} Hz must lie in (0, {fs / 2:g}) Hz (the Nyquist frequency)")
    return filtfilt(signal.butter(order, cutoff_hz / (fs / 2), output="sos"), order, q,
                    f"the order-{order} Butterworth filter")


def filtfilt(sos: np.ndarray, order: int, x: np.ndarray, what: str) -> np.ndarray:
    """Forward–backward IIR filter (second-order sections ``sos`` of a filter of ``order``) along
    axis 0, padded as MATLAB's filtfilt (3·order samples, odd reflection), which the benchmark's
    reference figures depend on."""
    pad = 3 * order
    if x.shape[0] <= pad:
        raise TooFewSamples(f"{x.shape[0]} samples are too few for {what} (needs more than {pad})")
    return signal.sosfiltfilt(sos, x, axis=0, padlen=pad)


def central_difference(y: np.ndarray, dt: float) -> np.ndarray:
    """(y[k+1] − y[k−1]) / 2dt inside, one-sided at the ends; along axis 0."""
    return np.gradient(y, dt, axis=0, edge_order=1)


def decimate(x: np.ndarray, n: int, stride: int = 1, rows: np.ndarray | None = None) -> np.ndarray:
    """MATLAB-style decimation of each column of x (N, …) by n.

    Chebyshev type I low-pass (order 8, 0.05 dB ripple, cut-off 0.8/n of Nyquist) applied
    forward–backward, then every n-th sample kept, aligned to the last sample.

    ``stride`` (a divisor of n): x holds every ``stride``-th sample only (aligned to the last,
    :func:`decimation_indices`); the filter keeps the same band in Hz (cut-off 0.8·stride/n of
    x's Nyquist) and the rows are the same instants. ``rows``: only these of the decimated rows.
    """
    if n == 1:
        return x if rows is None else x[rows]
    kept = decimation_indices(x.shape[0], n // stride)
    if rows is not None:
        kept = kept[rows]
    sos = signal.cheby1(8, 0.05, 0.8 * stride / n, output="sos")
    what = f"the anti-alias filter of decimation by {n}"
    if x.ndim == 1:
        return filtfilt(sos, 8, x, what)[kept]
    # column by column (each is filtered alone), in blocks to bound the filter's work arrays;
    # all-zero columns (a robot regressor's block of a joint a body does not load) stay zero
    flat = x.reshape(x.shape[0], -1)
    out = np.zeros((kept.size, flat.shape[1]))
    live = np.flatnonzero(np.any(flat, axis=0))
    if live.size == 0:
        live = np.arange(min(1, flat.shape[1]))
    for c0 in range(0, live.size, _FILTER_COLUMNS):
        cols = live[c0 : c0 + _FILTER_COLUMNS]
        out[:, cols] = filtfilt(sos, 8, flat[:, cols], what)[kept]
    return out.reshape((kept.size,) + x.shape[1:])


def decimation_indices(length: int, n: int) -> np.ndarray:
    """Indices kept by decimating ``length`` samples by n: every n-th, aligned to the last."""
    start = n - (n * int(np.ceil(length / n)) - length)  # 1-based, as MATLAB's decimate
    return np.arange(start - 1, length, n)


# -------------------------------------------------------------- noise and bandwidth
def noise_density(x: np.ndarray, fs: float) -> np.ndarray:
    """(J,) one-sided white-noise PSD level (unit²/Hz) of each column of x (N, J), from the
    median periodogram over NOISE_BAND·fs."""
    f, P = signal.periodogram(x, fs, window="hann", detrend="linear", axis=0)
    band = (f >= NOISE_BAND[0] * fs) & (f <= NOISE_BAND[1] * fs)
    if not band.any():
        return np.zeros(x.shape[1])
    return np.median(P[band], axis=0) / np.log(2)


def motion_bandwidth(q: np.ndarray, fs: float, n0: np.ndarray) -> np.ndarray:
    """(J,) frequency (Hz) below which BANDWIDTH_SHARE of each joint's motion q̇ power lies, the
    differentiated position noise (density ``n0``) removed; nan without motion above the noise."""
    f, P = signal.periodogram(central_difference(q, 1.0 / fs), fs, window="hann", detrend="linear", axis=0)
    P = np.clip(P - (fs * np.sin(2 * np.pi * f / fs))[:, None] ** 2 * n0[None], 0.0, None)
    c = np.cumsum(P, axis=0)
    out = np.full(q.shape[1], np.nan)
    for j in np.flatnonzero(c[-1] > 0):
        out[j] = f[np.searchsorted(c[:, j] / c[-1, j], BANDWIDTH_SHARE)]
    return out


def differentiated_noise_var(n0: np.ndarray, fs: float, cutoff_hz: float | None, order: int,
                             differences: int) -> np.ndarray:
    """(J,) variance that white noise of density ``n0`` keeps after the forward–backward
    Butterworth (none when ``cutoff_hz`` is None) and ``differences`` central differences:
    n0·∫₀^{fs/2} |H(f)|⁴·(fs·sin(2πf/fs))^(2·differences) df."""
    f = np.linspace(0.0, fs / 2, _GRID)[1:]
    gain = (fs * np.sin(2 * np.pi * f / fs)) ** (2 * differences)
    if cutoff_hz is not None:
        _, h = signal.sosfreqz(signal.butter(order, cutoff_hz / (fs / 2), output="sos"), worN=f, fs=fs)
        gain = gain * np.abs(h) ** 4
    return n0 * np.trapezoid(gain, f)


# ---------------------------------------------------------------------- the rule
def choose_preprocessing(series: JointSeries, requested: Preprocessing | None = None
                         ) -> tuple[Preprocessing, dict]:
    """Resolve the unset settings of ``requested`` (default: all unset) from the data of
    ``series`` (uniform stamps) with the rule of the module doc.

    Returns the resolved settings and a JSON-ready report: sample_rate_hz, analysis_rate_hz,
    from_data (the settings chosen here), bandwidth_hz (and per joint), moving joints, position
    and velocity noise σ per joint, and what the q̈ noise statistic of :func:`preprocess` needs
    (``_qdd_noise``, not for JSON).
    """
    req = requested or Preprocessing()
    fs = 1.0 / series.dt
    joints = list(series.joints)
    if req.cutoff_hz is not None and req.cutoff_hz >= fs / 2:
        raise InputError(f"{series.source}: cut-off {req.cutoff_hz:g} Hz at or above the Nyquist frequency "
                         f"{fs / 2:.6g} Hz of data sampled at {fs:.6g} Hz; give a lower one (--cutoff HZ)")
    n0 = noise_density(series.position, fs)
    sigma_q = np.sqrt(n0 * fs / 2)
    moving = np.ptp(series.position, axis=0) > MOVING_FACTOR * sigma_q
    bandwidth = np.where(moving, motion_bandwidth(series.position, fs, n0), np.nan)
    from_data = []
    cutoff = req.cutoff_hz
    if cutoff is None:
        if not np.any(np.isfinite(bandwidth)):
            raise InputError(f"{series.source}: no joint moves more than {MOVING_FACTOR:g}× its position noise "
                             f"(σ_q {_per_joint(joints, sigma_q)}): the cut-off cannot be chosen from the data; "
                             "give one (--cutoff HZ)")
        cutoff = float(min(CUTOFF_PER_BANDWIDTH * np.nanmax(bandwidth), MAX_CUTOFF_SHARE * fs))
        if not cutoff > 0:  # a record too short to show its motion's frequencies
            raise InputError(f"{series.source}: {len(series)} samples ({series.t[-1] - series.t[0]:.4g} s) show no "
                             "motion bandwidth: the cut-off cannot be chosen from the data; record longer motion or "
                             "give one (--cutoff HZ)")
        from_data.append("cutoff_hz")
    dec = req.decimate
    if dec is None:
        dec = rule_decimation(fs, cutoff)
        from_data.append("decimate")
    trim = min(TRIM_PERIODS / cutoff, MAX_TRIM_SHARE * (series.t[-1] - series.t[0]))
    trims = {}
    for name in ("trim_start_s", "trim_end_s"):
        trims[name] = getattr(req, name)
        if trims[name] is None:
            trims[name] = trim
            from_data.append(name)
    filtered = None if req.filter == "none" else cutoff
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
    settings = Preprocessing(cutoff, req.order, dec, trims["trim_start_s"], trims["trim_end_s"], min_speed,
                             req.velocity, req.filter, req.metric, req.thin, req.dip_scale)
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


# ------------------------------------------------------------------------ prepare
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

    def smooth(x: np.ndarray) -> np.ndarray:
        return x if settings.filter == "none" else lowpass_position(x, fs, settings.cutoff_hz, settings.order)

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
    keep DIP_FACTOR·f; and the position filter must keep f/DIP_FACTOR, or the filtered velocity
    misplaces the dip (both calibrated on the synthetic TX40 recordings: vs and δ within 5 %;
    coarser choices bias δ by 10–70 %)."""
    if reversal_acceleration <= 0 or speed_scale <= 0:
        return np.iinfo(np.int32).max, 0.0
    f = reversal_acceleration / (np.pi * speed_scale)
    return max(1, int(np.floor(0.4 * fs / (DIP_FACTOR * f)))), min(f / DIP_FACTOR, MAX_CUTOFF_SHARE * fs)


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
    return max(k for k in range(1, n + 1)
               if n % k == 0 and (k == 1 or fs / k >= SMOOTH_RATE_PER_CUTOFF * settings.cutoff_hz))


def subsample(prepared: Prepared, stride: int) -> Prepared:
    """Every ``stride``-th sample of ``prepared``, aligned to the last (:func:`decimation_indices`)."""
    if stride == 1:
        return prepared
    k = decimation_indices(prepared.t.size, stride)
    return Prepared(prepared.t[k], prepared.q[k], prepared.qd[k], prepared.qdd[k], prepared.tau[k],
                    prepared.dt * stride)


def rule_decimation(fs: float, cutoff_hz: float) -> int:
    """The decimation that keeps the analysis rate ≥ ANALYSIS_PER_CUTOFF × the cut-off."""
    return max(1, int(np.floor(fs / (ANALYSIS_PER_CUTOFF * cutoff_hz))))


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
    share of the filtered q̈ variance that is differentiated position noise), and the notes of
    what was done to the stamps.
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
    filtered = None if settings.filter == "none" else settings.cutoff_hz
    noise = differentiated_noise_var(n0, fs, filtered, settings.order, differences)
    var = np.var(prepared.qdd, axis=0)
    share = np.where(var > 0, noise / np.where(var > 0, var, 1.0), np.nan)
    report["qdd_noise_share"] = _per_joint(list(series.joints), share)
    report["reversal_acceleration"] = _per_joint(list(series.joints), reversal_acceleration(prepared))
    report["resampled_samples"] = len(series) if notes else 0
    return prepared, settings, report, notes
