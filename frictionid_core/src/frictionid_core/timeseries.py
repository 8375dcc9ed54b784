"""The one time-series structure every loader returns."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from frictionid_core.errors import InputError

# An interval longer than this many sample periods and SEGMENT_GAP_S (a clock jump, a paused
# recording) splits a series into segments that are filtered alone (:meth:`JointSeries.segments`).
# Shorter gaps (messages lost in bursts) are interpolated by the resampling: cutting there costs
# the filters' trims (5/fc at each side) and, on a stream losing a burst every fraction of a
# second, most of the data (on the TX40 excitation with 20 bursts of 11–60 ms lost in 6 s: the
# validation error 1.3 % interpolated, 15–17 % cut).
SEGMENT_GAP_PERIODS = 10.0
SEGMENT_GAP_S = 0.2


@dataclass
class JointSeries:
    """Joint measurements sampled at times ``t``.

    Attributes:
        t: sample times, s, shape (N,), strictly increasing.
        joints: joint names, length J.
        position: joint positions, m or rad, shape (N, J).
        effort: joint force/torque, N or N·m, shape (N, J).
        velocity: recorded joint velocities, m/s or rad/s, shape (N, J), or None.
        source: where the data came from (for messages and reports).
        extras: other named signals on the same time base (e.g. EMPS ``qg``), each (N,) or (N, J).
        meta: scalar facts about the recording (e.g. EMPS ``gtau``, ``kp``, ``kv``).
        notes: what the loader did to the data (e.g. dropped duplicated stamps).
    """

    t: np.ndarray
    joints: list[str]
    position: np.ndarray
    effort: np.ndarray
    velocity: np.ndarray | None = None
    source: str = ""
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float).ravel()
        self.position = _as_2d(self.position, "position", self.source)
        self.effort = _as_2d(self.effort, "effort", self.source)
        if self.velocity is not None:
            self.velocity = _as_2d(self.velocity, "velocity", self.source)
        n, nj = len(self.t), len(self.joints)
        for name in ("position", "effort", "velocity"):
            arr = getattr(self, name)
            if arr is None:
                continue
            if arr.shape[0] != n:
                raise InputError(
                    f"{self.source}: field '{name}' has {arr.shape[0]} samples but there are {n} time stamps"
                )
            if arr.shape[1] != nj:
                raise InputError(
                    f"{self.source}: field '{name}' has {arr.shape[1]} columns for {nj} joints {self.joints}"
                )

    def __len__(self) -> int:
        return len(self.t)

    @property
    def dt(self) -> float:
        """Mean sample period, s."""
        return float((self.t[-1] - self.t[0]) / (len(self.t) - 1))

    def select(self, joints: list[str]) -> JointSeries:
        """Return the series restricted to ``joints`` (in that order)."""
        missing = [j for j in joints if j not in self.joints]
        if missing:
            raise InputError(
                f"{self.source}: joint(s) {missing} not present; joints in the data: {self.joints}"
            )
        idx = [self.joints.index(j) for j in joints]
        pick = lambda a: None if a is None else a[:, idx]
        extras = {k: (v[:, idx] if v.ndim == 2 and v.shape[1] == len(self.joints) else v)
                  for k, v in self.extras.items()}
        return JointSeries(self.t, list(joints), pick(self.position), pick(self.effort),
                           pick(self.velocity), self.source, extras, dict(self.meta), list(self.notes))

    def take(self, index: np.ndarray) -> JointSeries:
        """Samples at ``index`` (integer indices or a boolean mask of length N) as a new series."""
        pick = lambda a: None if a is None else a[index]
        return JointSeries(self.t[index], list(self.joints), self.position[index], self.effort[index],
                           pick(self.velocity), self.source, {k: v[index] for k, v in self.extras.items()},
                           dict(self.meta), list(self.notes))

    def slice(self, start: int, stop: int) -> JointSeries:
        """Samples ``start:stop`` (indices) as a new series."""
        cut = lambda a: None if a is None else a[start:stop]
        return JointSeries(self.t[start:stop], list(self.joints), cut(self.position),
                           cut(self.effort), cut(self.velocity), self.source,
                           {k: v[start:stop] for k, v in self.extras.items()}, dict(self.meta),
                           list(self.notes))

    def segment_bounds(self) -> list[tuple[int, int]]:
        """(start, stop) sample indices of the pieces between the gaps of the stamps: intervals
        longer than SEGMENT_GAP_PERIODS :func:`sample_period` and SEGMENT_GAP_S; one piece
        without gaps."""
        gap = max(SEGMENT_GAP_PERIODS * sample_period(self.t), SEGMENT_GAP_S)
        cuts = np.flatnonzero(np.diff(self.t) > gap) + 1
        edges = [0, *cuts.tolist(), len(self)]
        return list(zip(edges[:-1], edges[1:]))

    def segments(self) -> list[JointSeries]:
        """The series cut at the gaps of its stamps (see :meth:`segment_bounds`), pieces in time order."""
        bounds = self.segment_bounds()
        return [self] if len(bounds) == 1 else [self.slice(a, b) for a, b in bounds]

    def window(self, start_s: float | None = None, end_s: float | None = None) -> JointSeries:
        """The samples from ``start_s`` to ``end_s`` (both included), in seconds from the first sample;
        None: from the first / to the last sample.

        An end more than 1.5 sample periods past the last sample ends the window there (noted in
        ``notes`` and warned).

        Raises:
            InputError: a negative or non-finite bound, ``end_s <= start_s``, a start at or past the
                last sample, or a window holding fewer than 2 samples.
        """
        src = self.source or "data"
        for name, value in (("start", start_s), ("end", end_s)):
            if value is not None and (not math.isfinite(value) or value < 0.0):
                raise InputError(f"{src}: window {name} {value} s: expected a finite time >= 0 s from the first sample")
        if start_s is not None and end_s is not None and end_s <= start_s:
            raise InputError(f"{src}: window end {end_s:g} s is not after its start {start_s:g} s")
        elapsed = self.t - self.t[0]
        duration = float(elapsed[-1])
        start = 0.0 if start_s is None else float(start_s)
        if start >= duration:
            raise InputError(f"{src}: window start {start:g} s is beyond the data, which lasts {duration:.6g} s")
        tol = 1e-9 * max(duration, 1.0)  # stamps a rounding error away from a bound belong to the window
        lo = int(np.searchsorted(elapsed, start - tol, side="left"))
        hi = len(self) if end_s is None else int(np.searchsorted(elapsed, end_s + tol, side="right"))
        if hi - lo < 2:
            raise InputError(f"{src}: window {start:g}–{'end' if end_s is None else f'{end_s:g} s'} holds "
                             f"{hi - lo} sample(s); it needs at least 2")
        out = self.slice(lo, hi)
        if end_s is not None and end_s > duration + 1.5 * self.dt:
            note = f"{src}: window end {end_s:g} s is past the last sample: the window ends there ({duration:.6g} s)"
            out.notes.append(note)
            warnings.warn(note, stacklevel=2)
        return out


def sample_period(t: np.ndarray) -> float:
    """The typical interval of the stamps ``t`` (s): the mean of the positive intervals once those
    longer than SEGMENT_GAP_PERIODS of it (gaps) are left out; 0 without a positive interval."""
    dt = np.diff(np.asarray(t, dtype=float))
    dt = dt[dt > 0]
    period = float(dt.mean()) if dt.size else 0.0
    while dt.size:
        inside = dt <= SEGMENT_GAP_PERIODS * period
        if inside.all():
            break
        dt = dt[inside]
        period = float(dt.mean())
    return period


def _as_2d(a, name: str, source: str) -> np.ndarray:
    arr = np.asarray(a, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise InputError(f"{source}: field '{name}' must be 1-D or 2-D, got shape {arr.shape}")
    return arr
