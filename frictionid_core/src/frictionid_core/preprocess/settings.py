"""The pre-processing settings (:class:`Preprocessing`), the prepared signals (:class:`Prepared`)
and the constants of the rule (:mod:`frictionid_core.preprocess.rule`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from frictionid_core.errors import FrictionIdError, InputError, check_choice

# Where identification takes q̇ from: the central difference of the filtered position, or the
# logged velocity low-passed the same way.
VELOCITY_SOURCES = ("position", "recorded")
# q̈ is noise-dominated when differentiated position noise makes up more than this share of its
# filtered variance (inertias then come out low by about 1.5–2 × the share): the cut-off rule's limit
# and the warning's.
QDD_NOISE_SHARE_LIMIT = 0.02

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
# Rows within this many periods of a joint's cut-off of one of its reversals are left out by a fit
# whose law has no dip: the zero-phase order-4 Butterworth spreads a step (a stick, a slip) over
# ±0.29/fc (2 % to 98 % of its step response), so the filtered q̈ and sign(q̇) misstate the rows
# there; a ground-truth UR5 (MuJoCo friction) gave rotor inertias 3–8 % high with them, ≤ 1.4 % without.
REVERSAL_PERIODS = 0.3
# Rows of a run of one sign of motion shorter than this many periods of the joint's cut-off are left out
# by a static law's fit (Preprocessing.brief_periods): a motion the filter passes (below its cut-off)
# stays on one side of the min speed for longer; the filter's ringing after a stop (order 4, zero
# phase: lobes of ~1 % of the decelerating speed) or noise does not — on a Stribeck joint those rows
# carried ±Fs of the wrong sign.
BRIEF_PERIODS = 0.5
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
        reversal_periods: rows within this many periods of a joint's cut-off (reversal_periods /
            cut-off, s) of one of its reversals (a sign change of its velocity) are left out, counted
            apart: the filter spreads a stick or slip at a reversal over that time; 0 keeps them;
            None: chosen by the identification (:data:`REVERSAL_PERIODS` for a law without a dip
            whose min speed comes from the data, else 0).
        brief_periods: rows of a run of one sign of motion shorter than this many periods of the
            joint's cut-off are left out, counted apart (``brief_motion_rows``): no motion below the
            cut-off is that brief; 0 keeps them; None: :data:`BRIEF_PERIODS` for a static law
            with a min speed above 0, else 0 (a dynamic law models small motions).
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
    reversal_periods: float | None = None
    brief_periods: float | None = None

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
                  *(("min_speed", v, 0, True) for v in speeds), ("reversal_periods", self.reversal_periods, 0, True),
                  ("brief_periods", self.brief_periods, 0, True)]
        bad = [f"{name} {value}" for name, value, low, inclusive in limits
               if value is not None and (value < low or (value == low and not inclusive))]
        if bad:
            raise FrictionIdError(f"pre-processing: invalid {', '.join(bad)} (cut-off > 0, order, decimate and thin "
                                  "≥ 1, trims, min speed, reversal and brief periods ≥ 0)")

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




def joint_cutoffs(cutoff_hz: float | dict[str, float], joints: list[str]) -> np.ndarray:
    """(J,) the cut-off of each of ``joints`` from one value or a {joint: Hz} mapping."""
    if isinstance(cutoff_hz, dict):
        return np.array([float(cutoff_hz[j]) for j in joints])
    return np.full(len(joints), float(cutoff_hz))


def cutoff_range(cutoff_hz: float | dict[str, float]) -> tuple[float, float]:
    """(lowest, highest) cut-off of a setting (one value or {joint: Hz})."""
    values = list(cutoff_hz.values()) if isinstance(cutoff_hz, dict) else [cutoff_hz]
    return float(min(values)), float(max(values))
