"""A separately recorded effort stream put on the joint-state samples."""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.io.checks import MIN_SAMPLES
from frictionid_core.timeseries import JointSeries


def align_effort(series: JointSeries, t_effort: np.ndarray, effort: np.ndarray, what: str, *,
                 at: np.ndarray | None = None, min_samples: int = MIN_SAMPLES) -> JointSeries:
    """``series`` with the effort stream interpolated (linearly) at its samples.

    Joint states outside the stream's time range are dropped, with a note in ``notes``.

    Args:
        series: joint states; their own ``effort`` is replaced.
        t_effort: times of the effort samples [s], (M,), any order, on the clock of ``at``.
        effort: efforts (M, J), columns in ``series.joints`` order [N·m | N].
        what: the stream in messages, e.g. ``"effort topic '/effort'"``.
        at: times of the joint states on the stream's clock [s], (N,); default ``series.t``
            (the node passes receipt times to pair an unstamped stream).
        min_samples: fewest joint states the stream must overlap.

    Raises:
        InputError: naming ``series.source`` and ``what`` (no samples, wrong shape, too little overlap).
    """
    t_effort = np.asarray(t_effort, dtype=float).ravel()
    effort = np.asarray(effort, dtype=float)
    if t_effort.size == 0:
        raise InputError(f"{series.source}: {what} has no samples")
    if effort.shape != (t_effort.size, len(series.joints)):
        raise InputError(f"{series.source}: {what} has efforts of shape {effort.shape} for {t_effort.size} stamps "
                         f"and {len(series.joints)} joints {series.joints}")
    at = series.t if at is None else np.asarray(at, dtype=float)
    order = np.argsort(t_effort, kind="stable")
    t_effort, effort = t_effort[order], effort[order]
    inside = (at >= t_effort[0]) & (at <= t_effort[-1])
    kept = int(np.count_nonzero(inside))
    if kept < max(min_samples, 1):
        raise InputError(f"{series.source}: too little data: {what} overlaps only {kept} of {len(series)} "
                         f"joint-state samples in time (need at least {min_samples})")
    out = series.take(inside)
    out.effort = np.column_stack([np.interp(at[inside], t_effort, column) for column in effort.T])
    dropped = len(series) - kept
    if dropped:
        out.notes.append(f"{dropped} joint-state samples outside the time range of {what} dropped")
    return out
