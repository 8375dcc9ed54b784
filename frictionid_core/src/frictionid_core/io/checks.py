"""Sanity checks shared by every loader: finite samples, ordered unique stamps; lost samples."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.timeseries import JointSeries

MIN_SAMPLES = 3
GAP_FACTOR = 1.5  # an interval longer than this many median periods is a gap


def check_series(series: JointSeries, *, strict_time: bool = False) -> JointSeries:
    """Validate ``series``; repair stamp order/duplicates unless ``strict_time``.

    Repairs are recorded in ``series.notes`` and issued as a ``UserWarning``.
    """
    src = series.source
    if len(series) < MIN_SAMPLES:
        done = f" ({'; '.join(series.notes)})" if series.notes else ""
        raise InputError(f"{src}: only {len(series)} samples; at least {MIN_SAMPLES} are needed{done}")
    if not np.all(np.isfinite(series.t)):
        bad = np.flatnonzero(~np.isfinite(series.t))
        raise InputError(f"{src}: {bad.size} non-finite time stamps (first at sample {bad[0]})")
    for name in ("position", "effort", "velocity"):
        arr = getattr(series, name)
        if arr is None:
            continue
        bad = ~np.isfinite(arr)
        if bad.any():
            col = int(np.flatnonzero(bad.any(axis=0))[0])
            rows = np.flatnonzero(bad[:, col])
            raise InputError(
                f"{src}: {int(bad.sum())} NaN/inf samples in field '{name}' "
                f"(joint '{series.joints[col]}': {rows.size}, first at t = {series.t[rows[0]]:.6g} s)"
            )
    return _order_stamps(series, strict_time)


def _order_stamps(series: JointSeries, strict: bool) -> JointSeries:
    dt = np.diff(series.t)
    n_back = int(np.count_nonzero(dt < 0))
    n_dup = int(np.count_nonzero(dt == 0))
    if n_back == 0 and n_dup == 0:
        return series
    src = series.source
    if strict:
        raise InputError(
            f"{src}: time stamps not strictly increasing: {n_back} go backwards, {n_dup} duplicated"
        )
    order = np.argsort(series.t, kind="stable")
    t_sorted = series.t[order]
    keep = np.concatenate(([True], np.diff(t_sorted) > 0))
    idx = order[keep]
    n_dropped = len(series) - idx.size
    out = series.take(idx)
    msgs = []
    if n_back:
        msgs.append(f"{n_back} out-of-order time stamps: samples re-sorted by time")
    if n_dropped:
        msgs.append(f"{n_dropped} samples with duplicated time stamps dropped (first kept)")
    for m in msgs:
        note = f"{src}: {m}"
        out.notes.append(note)
        warnings.warn(note, stacklevel=3)
    if len(out) < MIN_SAMPLES:
        raise InputError(f"{src}: only {len(out)} samples left after removing duplicated stamps")
    return out


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
