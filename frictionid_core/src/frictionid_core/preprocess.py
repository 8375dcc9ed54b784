"""Signal preparation for inverse-dynamic identification (docs/reference.md#emps-idim-ls).

Zero-phase Butterworth on position, central differences for velocity and acceleration,
edge trimming, and parallel decimation (low-pass + keep 1 of n) of every observation column
and of the torque. Irregular stamps are first resampled onto a uniform grid.

Settings left unset (None) are chosen from the data by :func:`choose_preprocessing`:

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
  :mod:`frictionid_core.identification.stick`) are left out as the slow rows are, and counted apart.

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
CUTOFF_PER_BANDWIDTH = 10.0  # the cut-off is at least this × the motion bandwidth (where credible) …
MAX_CUTOFF_SHARE = 0.2  # … at most this × fs (0.4 × Nyquist) …
MIN_CUTOFF_BINS = 4.0  # … and at least this many periodogram bins (fs / N each)
CUTOFF_GRID = 160  # cut-offs tried, log-spaced between those bounds, for the position's bound
CUTOFFS_PER_DECADE = 6  # the fixed grid of cut-offs tried for the effort's prediction (a ratio 1.47)
PREDICTION_TOLERANCE = 0.01  # … the lowest cut-off whose residual is within this share of the least one
PREDICTION_ROWS = 50_000  # the effort's prediction uses at most about this many rows (every k-th)
ANALYSIS_PER_CUTOFF = 10.0  # analysis rate ≥ this × the lowest fc …
ALIAS_BAND_SHARE = 0.4  # … and its anti-alias band (this × the analysis rate) …
ALIAS_BAND_PER_CUTOFF = 1.5  # … ≥ this × the highest fc
TRIM_PERIODS = 5.0  # trims of this many 1/fc at each end …
MAX_TRIM_SHARE = 0.1  # … at most this share of the record each
MIN_SPEED_SIGMAS = 10.0  # slow rows: |q̇| < max(this × σ_q̇, …
MIN_SPEED_SHARE = 5e-4  # … this × the joint's top speed)
DIP_FACTOR = 6.0  # friction dips: anti-alias band ≥ this × a/(π·vs) …
DIP_CUTOFF_FACTOR = 3.0  # … cut-off ≥ a/(π·vs) / this
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
        cutoff_hz: Butterworth cut-off on position (and on a recorded velocity), Hz: one value for
            every joint or {data joint: Hz} (chosen from the data: one per joint).
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
        stick_speed: {row joint: speed} below which its rows stick (friction below its level; set
            by the identification's stick detection): left out like the slow rows, counted apart.
    """

    cutoff_hz: float | dict[str, float] | None = None
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
    stick_speed: dict[str, float] | None = None

    def __post_init__(self) -> None:
        for name, value, choices in (("velocity", self.velocity, VELOCITY_SOURCES),
                                     ("filter", self.filter, FILTERS), ("metric", self.metric, METRIC_EFFORTS)):
            check_choice(f"pre-processing {name}", value, choices, name)
        speeds = self.min_speed.values() if isinstance(self.min_speed, dict) else [self.min_speed]
        cutoffs = self.cutoff_hz.values() if isinstance(self.cutoff_hz, dict) else [self.cutoff_hz]
        # (name, value, lowest allowed, allowed itself)
        limits = [*(("cutoff_hz", v, 0, False) for v in cutoffs), ("order", self.order, 1, True),
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
def lowpass_position(q: np.ndarray, fs: float, cutoff_hz: float | np.ndarray, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth (forward–backward) of each column of q (N, J) at ``cutoff_hz``: one
    value, or one per column (J,)."""
    cutoffs = np.broadcast_to(np.asarray(cutoff_hz, dtype=float), (q.shape[1],))
    bad = [c for c in np.unique(cutoffs) if not 0.0 < c < fs / 2]
    if bad:
        raise InputError(f"filter cut-off {bad[0]:g} Hz must lie in (0, {fs / 2:g}) Hz (the Nyquist frequency)")
    out = np.empty(q.shape)
    for fc in np.unique(cutoffs):
        cols = cutoffs == fc
        out[:, cols] = filtfilt(signal.butter(order, fc / (fs / 2), output="sos"), order, q[:, cols],
                                f"the order-{order} Butterworth filter")
    return out


def joint_cutoffs(cutoff_hz: float | dict[str, float], joints: list[str]) -> np.ndarray:
    """(J,) the cut-off of each of ``joints`` from one value or a {joint: Hz} mapping."""
    if isinstance(cutoff_hz, dict):
        return np.array([float(cutoff_hz[j]) for j in joints])
    return np.full(len(joints), float(cutoff_hz))


def cutoff_range(cutoff_hz: float | dict[str, float]) -> tuple[float, float]:
    """(lowest, highest) cut-off of a setting (one value or {joint: Hz})."""
    values = list(cutoff_hz.values()) if isinstance(cutoff_hz, dict) else [cutoff_hz]
    return float(min(values)), float(max(values))


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
        _, h = signal.sosfreqz(signal.butter(order, fc / (fs / 2), output="sos"), worN=f, fs=fs)
        out[cutoffs == fc] = np.trapezoid(gain * np.abs(h) ** 4, f)
    return n0 * out


def risk_cutoffs(q: np.ndarray, fs: float, n0: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Per column of q (N, J): (the cut-off in Hz that minimises the estimated mean-square error of
    the filtered acceleration, True where that is the highest cut-off allowed) — see the module doc.

    The periodogram's P − N0 is an unbiased estimate of the motion's spectrum, so the risk is
    too, bin by bin; its sum over thousands of bins varies little, and only its minimiser is used."""
    f, P = signal.periodogram(q, fs, window="hann", detrend="linear", axis=0)
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


def cutoff_interval(series: JointSeries, order: int = 4) -> dict[str, tuple[float, float]]:
    """{moving joint: (lowest, highest cut-off in Hz)} the rule allows on ``series`` (uniform
    stamps): :func:`rule_interval`; a cut-off inside keeps the joint's motion and stays below its
    position noise."""
    fs = 1.0 / series.dt
    n0 = noise_density(series.position, fs)
    moving = np.ptp(series.position, axis=0) > MOVING_FACTOR * np.sqrt(n0 * fs / 2)
    bandwidth = np.where(moving, motion_bandwidth(series.position, fs, n0), np.nan)
    floor, ceiling, _ = rule_interval(series.position, fs, n0, bandwidth, order)
    return {j: (float(floor[k]), float(ceiling[k])) for k, j in enumerate(series.joints) if moving[k]}


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
    from frictionid_core.diagnostics import QDD_NOISE_SHARE_LIMIT  # diagnostics imports the model, which imports us

    f, P = signal.periodogram(q, fs, window="hann", detrend="linear", axis=0)
    weight = (fs * np.sin(2 * np.pi * f / fs)) ** (2 * differences)
    df = f[1] - f[0]
    grid = np.geomspace(MIN_CUTOFF_BINS * fs / q.shape[0], MAX_CUTOFF_SHARE * fs, CUTOFF_GRID)
    out = np.full(q.shape[1], np.nan)
    for fc in grid:
        gain2 = (1.0 / (1.0 + (f / fc) ** (2 * order))) ** 2
        total = (gain2 * weight) @ P * df  # the filtered q̈ variance (motion + noise)
        noise = differentiated_noise_var(n0, fs, fc, order, differences)
        ok = noise <= QDD_NOISE_SHARE_LIMIT * total
        out[ok] = fc
    return out


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
    settings = Preprocessing(cutoff, req.order, dec, trims["trim_start_s"], trims["trim_end_s"], min_speed,
                             req.velocity, req.filter, req.metric, req.thin, req.dip_scale, req.stick_speed)
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


def rule_decimation(fs: float, cutoff_hz: float | dict[str, float]) -> int:
    """The decimation that keeps the analysis rate ≥ ANALYSIS_PER_CUTOFF × the lowest cut-off (one
    value or {joint: Hz}) and the anti-alias band ≥ ALIAS_BAND_PER_CUTOFF × the highest (see the
    module doc)."""
    low, high = cutoff_range(cutoff_hz)
    return max(1, int(np.floor(min(fs / (ANALYSIS_PER_CUTOFF * low),
                                   ALIAS_BAND_SHARE * fs / (ALIAS_BAND_PER_CUTOFF * high)))))


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
    joints = list(series.joints)
    filtered = None if settings.filter == "none" else joint_cutoffs(settings.cutoff_hz, joints)
    noise = differentiated_noise_var(n0, fs, filtered, settings.order, differences)
    var = np.var(prepared.qdd, axis=0)
    share = np.where(var > 0, noise / np.where(var > 0, var, 1.0), np.nan)
    report["qdd_noise_share"] = _per_joint(joints, share)
    # the cut-off a noise-dominated acceleration needs (named by the warning)
    from frictionid_core.diagnostics import QDD_NOISE_SHARE_LIMIT
    noisy = [j for j, s in enumerate(share) if joints[j] in report["moving_joints"] and s > QDD_NOISE_SHARE_LIMIT]
    clean = np.full(len(joints), np.nan)
    if noisy and settings.filter != "none":
        signal_of = recorded_velocity(uniform) if settings.velocity == "recorded" else uniform.position
        clean[noisy] = clean_acceleration_cutoff(signal_of[:, noisy], fs, n0[noisy], settings.order, differences)
    report["qdd_clean_cutoff_hz"] = {joints[j]: (float(clean[j]) if np.isfinite(clean[j]) else None) for j in noisy}
    report["reversal_acceleration"] = _per_joint(list(series.joints), reversal_acceleration(prepared))
    report["resampled_samples"] = len(series) if notes else 0
    return prepared, settings, report, notes
