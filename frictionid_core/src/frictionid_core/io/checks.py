"""Sanity checks shared by every loader (:func:`check_series`): broken and repeated rows
(:mod:`.rows`), ordered unique stamps, spikes, a lag of the logged velocity and effort; lost samples."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from frictionid_core.errors import InputError
from frictionid_core.io.rows import Origin, broken_rows, repeated_rows
from frictionid_core.timeseries import SEGMENT_GAP_PERIODS, SEGMENT_GAP_S, JointSeries, sample_period

MIN_SAMPLES = 3
GAP_FACTOR = 1.5  # an interval longer than this many median periods is a gap
# Spikes (see :func:`find_spikes`): a sample this many times further from the running median of
# its SPIKE_WINDOW neighbours than the signal's own sample-to-sample changes is a spike. On the real
# TX40, TIAGo and EMPS recordings no sample comes within 3.3 times of that scale; isolated glitches
# (a sensor read as 1e6, a dropped sign) are thousands of times above it.
SPIKE_FACTOR = 10.0
SPIKE_WINDOW = 11  # samples: runs of up to 3 spike samples are found
SPIKE_STEP_QUANTILE = 99.0  # the sample-to-sample change of a signal: this percentile of |Δx|
SPIKE_FIELDS = ("position", "effort", "velocity")
# Stamps whose intervals scatter by more than this share of the mean period are judged against the
# samples (:func:`_samples_on_a_clock`) …
CLOCK_JITTER = 0.05
# … and replaced by a uniform clock where the positions run at least this much smoother on it.
CLOCK_SMOOTHER = 2.0


def check_series(series: JointSeries, *, strict_time: bool = False, strict_rows: bool = False,
                 lines: np.ndarray | None = None) -> JointSeries:
    """Validate ``series`` and take out what is not a sample, in this order:

    * broken rows (:func:`~frictionid_core.io.rows.broken_rows`: a value NaN, inf or beyond any
      measurement, a stamp off the log's time line) are skipped (``strict_rows``: refused);
    * unless ``strict_time``, stamps are repaired (isolated wrong stamps, clock jumps back);
      disordered stamps are re-sorted (``strict_time``: refused);
    * repeated rows (:func:`~frictionid_core.io.rows.repeated_rows`: a sample recorded twice, a
      stale sample republished under a new stamp) are dropped (``strict_time``: duplicated stamps
      refused);
    * spike samples are replaced by interpolation (:func:`find_spikes`);
    * a lag of the logged velocity and effort behind the position is removed
      (:func:`frictionid_core.preprocess.remove_channel_lag`).

    ``lines``: the file line of each row (a CSV), for messages (else a row is named by its index).
    What was done is recorded in ``series.notes`` and issued as a ``UserWarning``, one per kind.
    """
    from frictionid_core.preprocess import remove_channel_lag

    src = series.source
    if len(series) < MIN_SAMPLES:
        done = f" ({'; '.join(series.notes)})" if series.notes else ""
        raise InputError(f"{src}: only {len(series)} samples; at least {MIN_SAMPLES} are needed{done}")
    origin = Origin.of(len(series), lines)
    notes = []
    broken = broken_rows(series, origin)
    restamp = np.flatnonzero(broken.restamp)
    if broken.mask.any():
        if strict_rows:
            raise broken.strict_error(series, origin)
        notes.append(broken.note(series, origin))
        keep = np.flatnonzero(~broken.mask)
        restamp = np.searchsorted(keep, restamp)
        series, origin = series.take(keep), origin.take(keep)
    if not strict_time:
        series = _repair_stamps(series, notes, origin, restamp)
        series = _samples_on_a_clock(series, notes)
    series, origin = _order_stamps(series, strict_time, notes, origin)
    series = _repair_spikes(series, notes)
    series, lag_note = remove_channel_lag(series)
    if lag_note:
        notes.append(lag_note)
    for note in notes:
        series.notes.append(note)
        warnings.warn(note, stacklevel=2)
    return series


def _repair_stamps(series: JointSeries, notes: list[str], origin: Origin,
                   glitches: np.ndarray | None = None) -> JointSeries:
    """Stamps out of line with both neighbours (spikes of the stamps, and ``glitches``: rows off
    the time line whose values are in line) interpolated between them; at a clock jump back longer
    than a gap (SEGMENT_GAP_PERIODS periods and SEGMENT_GAP_S), the later stamps shifted to follow
    after a gap as long as the jump (the gap splits the series: :meth:`JointSeries.segments`).
    Smaller steps back are disorder: :func:`_order_stamps` re-sorts them."""
    src = series.source
    t = series.t
    spikes = find_spikes(t)
    if glitches is not None and glitches.size:
        spikes = np.union1d(spikes, glitches)
    if spikes.size:
        t = t.copy()
        t[spikes] = _interpolated(np.arange(t.size, dtype=float), t, spikes)
        notes.append(f"{src}: {spikes.size} time stamp(s) out of line with both neighbours (first at "
                     f"{origin.name(spikes[0])}) replaced by interpolation between them")
    jumps = np.flatnonzero(np.diff(t) < -max(SEGMENT_GAP_PERIODS * sample_period(t), SEGMENT_GAP_S))
    if jumps.size:
        where = ", ".join(f"{t[k] - t[k + 1]:.6g} s back after t = {t[k] - t[0]:.6g} s" for k in jumps[:3])
        more = f" and {jumps.size - 3} more" if jumps.size > 3 else ""
        t = t.copy()
        for k in jumps:
            t[k + 1:] += 2.0 * (t[k] - t[k + 1])  # back by the jump → forward by the jump
        notes.append(f"{src}: the clock of the time stamps jumps back {jumps.size} time(s) ({where}{more}): the "
                     "stamps after a jump moved to follow after a gap as long as the jump, which cuts the log into "
                     "segments there")
    if t is series.t:
        return series
    return JointSeries(t, list(series.joints), series.position, series.effort, series.velocity, series.source,
                       dict(series.extras), dict(series.meta), list(series.notes))


def _samples_on_a_clock(series: JointSeries, notes: list[str]) -> JointSeries:
    """``series`` on a uniform clock in row order when its stamps scatter (by more than
    CLOCK_JITTER of the mean period) but its positions run CLOCK_SMOOTHER times smoother on that
    clock than on the stamps (the median |second divided difference| of each moving joint, their
    geometric mean): the samples were taken on a clock and stamped late by varying amounts (a
    driver stamping at receipt). Trusting such stamps turns their scatter into position noise
    (resampled onto a grid, or re-sorted where they step back). A log with gaps keeps its stamps."""
    t, q = series.t, series.position
    n = len(t)
    if n < 8 or t[-1] <= t[0]:
        return series
    period = (t[-1] - t[0]) / (n - 1)
    steps = np.diff(t)
    if np.std(steps) <= CLOCK_JITTER * period or steps.max() > SEGMENT_GAP_PERIODS * period:
        return series
    clock = t[0] + period * np.arange(n)
    moving = np.ptp(q, axis=0) > 0
    if not moving.any():
        return series
    with np.errstate(divide="ignore", invalid="ignore"):
        on_stamps, on_clock = (_roughness(times, q[:, moving]) for times in (t, clock))
        ratio = float(np.exp(np.mean(np.log(on_stamps / on_clock)))) if np.all(on_clock > 0) else np.inf
    if not ratio >= CLOCK_SMOOTHER:
        return series
    notes.append(f"{series.source}: the time stamps scatter by {np.std(steps) / period:.2g} of their mean period, "
                 f"but the positions run {ratio:.3g}× smoother on a uniform clock (their second differences): the "
                 f"samples were taken on a clock and stamped irregularly; the stamps replaced by a uniform "
                 f"{1 / period:.6g} Hz clock in row order")
    return JointSeries(clock, list(series.joints), series.position, series.effort, series.velocity, series.source,
                       dict(series.extras), dict(series.meta), list(series.notes))


def _roughness(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(J,) the median |second divided difference| of each column of ``q`` (N, J) at times ``t``
    (a stamp that steps back or repeats gives an infinite one, as a sample out of place is)."""
    v = np.diff(q, axis=0) / np.diff(t)[:, None]
    a = np.diff(v, axis=0) / (0.5 * (t[2:] - t[:-2]))[:, None]
    return np.median(np.abs(np.nan_to_num(a, nan=np.inf)), axis=0)


def _order_stamps(series: JointSeries, strict: bool, notes: list[str], origin: Origin
                  ) -> tuple[JointSeries, Origin]:
    """``series`` sorted by its stamps (a note says how many were out of order), without its
    repeated rows (:func:`~frictionid_core.io.rows.repeated_rows`, one note); ``strict``: InputError
    for stamps out of order or duplicated."""
    src = series.source
    dt = np.diff(series.t)
    n_back = int(np.count_nonzero(dt < 0))
    if strict:
        n_dup = int(np.count_nonzero(dt == 0))
        if n_back or n_dup:
            raise InputError(
                f"{src}: time stamps not strictly increasing: {n_back} go backwards, {n_dup} duplicated"
            )
    if n_back:
        order = np.argsort(series.t, kind="stable")
        series, origin = series.take(order), origin.take(order)
        notes.append(f"{src}: {n_back} out-of-order time stamps: samples re-sorted by time")
    repeated = repeated_rows(series)
    if repeated.mask.any():
        notes.append(repeated.note(series, origin))
        keep = np.flatnonzero(~repeated.mask)
        series, origin = series.take(keep), origin.take(keep)
        if len(series) < MIN_SAMPLES:
            raise InputError(f"{src}: only {len(series)} samples left after removing repeated rows")
    return series, origin


def find_spikes(x: np.ndarray) -> np.ndarray:
    """Indices of the spike samples of the signal ``x`` (N,), increasing.

    A sample is a spike when its distance to the median of the SPIKE_WINDOW samples around it
    exceeds SPIKE_FACTOR times the largest of: the signal's sample-to-sample change (the
    SPIKE_STEP_QUANTILE percentile of |Δx|), its resolution (the smallest nonzero |Δx|) and the
    spread of the middle five of those samples (steps, reversals and noise bursts stay inside it).
    The first and the last sample have neighbours on one side only, where a step (a synthetic
    log's friction vanishing at rest) looks the same: they are spikes only when they also lie
    further out than the span of the signal (its 0.5 to 99.5 percentiles).
    """
    x = np.asarray(x, dtype=float)
    half = SPIKE_WINDOW // 2
    if x.size < SPIKE_WINDOW:
        return np.empty(0, dtype=np.intp)
    step = np.abs(np.diff(x))
    moving = step[step > 0]
    if moving.size == 0:
        return np.empty(0, dtype=np.intp)
    scale = max(float(np.percentile(step, SPIKE_STEP_QUANTILE)), float(moving.min()))
    del step, moving
    residual = np.abs(x - ndimage.median_filter(x, size=SPIKE_WINDOW, mode="mirror"))
    candidates = np.flatnonzero(residual > SPIKE_FACTOR * scale)
    if candidates.size == 0:
        return candidates
    # the spread of the middle five of each candidate's window (mirrored at the ends, as the median)
    padded = np.pad(x, half, mode="reflect")
    window = np.sort(padded[candidates[:, None] + np.arange(SPIKE_WINDOW)], axis=1)
    spread = window[:, half + 2] - window[:, half - 2]
    spikes = candidates[residual[candidates] > SPIKE_FACTOR * np.maximum(scale, spread)]
    ends = (spikes == 0) | (spikes == x.size - 1)
    if ends.any():
        low, high = np.percentile(x, [0.5, 99.5])
        ends &= residual[spikes] <= high - low
        spikes = spikes[~ends]
    return spikes


def _repair_spikes(series: JointSeries, notes: list[str]) -> JointSeries:
    """``series`` with the spike samples of each field and joint (:func:`find_spikes`) replaced by
    linear interpolation in time between the nearest samples that are not spikes."""
    found = []
    for name in SPIKE_FIELDS:
        arr = getattr(series, name)
        if arr is None:
            continue
        for j in range(arr.shape[1]):
            spikes = find_spikes(arr[:, j])
            if spikes.size:
                found.append((name, j, spikes))
    if not found:
        return series
    fields = {name: getattr(series, name).copy() for name in dict.fromkeys(name for name, *_ in found)}
    parts = []
    for name, j, spikes in found:
        column = fields[name][:, j]
        worst = spikes[np.argmax(np.abs(column[spikes] - np.median(column)))]
        was = float(column[worst])
        column[spikes] = _interpolated(series.t, column, spikes)
        parts.append(f"joint '{series.joints[j]}' {name}: {spikes.size}, the largest {was:.6g} at "
                     f"{series.t[worst] - series.t[0]:.6g} s from the start (neighbours: {column[worst]:.6g})")
    total = sum(spikes.size for *_, spikes in found)
    notes.append(f"{series.source}: {total} spike sample(s) replaced by linear interpolation between their "
                 f"neighbours: {'; '.join(parts)}")
    return JointSeries(series.t, list(series.joints), fields.get("position", series.position),
                       fields.get("effort", series.effort), fields.get("velocity", series.velocity), series.source,
                       dict(series.extras), dict(series.meta), list(series.notes))


def _interpolated(t: np.ndarray, x: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """x at the indices ``bad``, interpolated linearly in ``t`` from the other samples."""
    good = np.ones(x.size, dtype=bool)
    good[bad] = False
    return np.interp(t[bad], t[good], x[good])


@dataclass(frozen=True)
class StampGaps:
    """Samples apparently lost between the stamps of a series (see :func:`stamp_gaps`)."""

    samples: int  # samples present
    missing: int  # samples estimated lost in the gaps
    gaps: int  # intervals longer than GAP_FACTOR median periods
    longest: float  # longest interval [s]
    period: float  # median interval [s]

    @property
    def missing_pct(self) -> float:
        """Share of the expected samples that are missing [%]."""
        return 100.0 * self.missing / (self.samples + self.missing)

    def __str__(self) -> str:
        return (f"about {self.missing} of {self.samples + self.missing} samples ({self.missing_pct:.2f} %) lost or "
                f"late ({self.gaps} gaps, longest {self.longest * 1e3:.1f} ms at a {self.period * 1e3:.3g} ms period)")


def stamp_gaps(series: JointSeries) -> StampGaps:
    """Lost samples estimated from the stamps of a checked series (increasing ``t``, >= 2 samples):
    an interval longer than GAP_FACTOR median periods is a gap that lost round(interval / period) - 1."""
    dt = np.diff(series.t)
    period = float(np.median(dt))
    gaps = dt > GAP_FACTOR * period
    n_gaps = int(np.count_nonzero(gaps))
    missing = int(np.round(dt[gaps] / period).sum()) - n_gaps
    return StampGaps(len(series), missing, n_gaps, float(dt.max()), period)
