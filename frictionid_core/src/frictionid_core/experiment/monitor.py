"""What stops a running experiment (no ROS import): the robot's measured joint states against the
commanded motion and the robot's effort limits, and the joint states themselves stopping.

:class:`Monitor` takes every measured sample (its stamp, positions, efforts) with the commanded
position at that stamp and says why the motion must stop, first reason first:

* ``tracking``: a joint further than ``tracking_rad`` from where it was commanded to be;
* ``effort``: a joint's measured effort beyond ``effort_ratio`` × its effort limit (strictly: a drive
  saturating at its limit is not beyond it), or not measured at all;
* ``silence``: no joint state for ``silence_s`` (checked against a clock by :meth:`Monitor.silent`).

It keeps the worst tracking error and effort ratio seen, for the feedback and the report.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from frictionid_core.errors import InputError

DEFAULT_TRACKING_RAD = 0.05  # [rad | m]
DEFAULT_EFFORT_RATIO = 1.0
DEFAULT_SILENCE_S = 0.25  # [s]
REASONS = ("tracking", "effort", "silence", "cancel")


@dataclass(frozen=True)
class Thresholds:
    """When a motion is stopped: ``tracking_rad`` [rad | m], ``effort_ratio`` (of each joint's effort
    limit), ``silence_s`` [s] (see the module docstring)."""

    tracking_rad: float = DEFAULT_TRACKING_RAD
    effort_ratio: float = DEFAULT_EFFORT_RATIO
    silence_s: float = DEFAULT_SILENCE_S

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"abort threshold {name} must be > 0, got {value:g}")

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Abort:
    """Why a motion was stopped: ``kind`` (one of :data:`REASONS`), one line ``text``, the stamp of
    the sample that showed it [s] (the clock's time for a silence or a cancel)."""

    kind: str
    text: str
    t: float


class Monitor:
    """The checks of the module docstring for ``joints`` with effort limits ``effort_limit`` (J,)
    [N·m | N; inf: none] under ``thresholds``."""

    def __init__(self, joints: list[str], effort_limit: np.ndarray, thresholds: Thresholds):
        self.joints = list(joints)
        self.limit = np.asarray(effort_limit, dtype=float)
        self.thresholds = thresholds
        self.max_tracking = np.zeros(len(self.joints))
        self.max_effort_ratio = np.zeros(len(self.joints))
        self.last_tracking = 0.0  # the largest |error| of the last batch [rad | m]
        self.last_t: float | None = None  # stamp of the newest sample [s]
        self.last_rx: float | None = None  # when the newest sample was received [s]
        self.samples = 0

    def check(self, t: np.ndarray, q: np.ndarray, effort: np.ndarray, q_ref: np.ndarray, rx=None) -> Abort | None:
        """Samples at stamps ``t`` (N,) [s], received at ``rx`` (N,) [s; default their stamps]: measured
        ``q``, ``effort`` and commanded ``q_ref`` (N, J); the first abort among them, or None."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.size == 0:
            return None
        self.samples += t.size
        self.last_t = float(t[-1]) if self.last_t is None else max(self.last_t, float(t[-1]))
        last_rx = float(np.max(rx)) if rx is not None else float(t[-1])
        self.last_rx = last_rx if self.last_rx is None else max(self.last_rx, last_rx)
        err = np.abs(np.asarray(q, float) - np.asarray(q_ref, float))
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.abs(np.asarray(effort, float)) / self.limit
        ratio = np.where(np.isfinite(self.limit), ratio, 0.0)
        self.last_tracking = float(np.nanmax(err)) if np.any(np.isfinite(err)) else float("nan")
        np.fmax(self.max_tracking, np.nanmax(np.where(np.isfinite(err), err, 0.0), axis=0), out=self.max_tracking)
        np.fmax(self.max_effort_ratio, np.nanmax(np.where(np.isfinite(ratio), ratio, 0.0), axis=0),
                out=self.max_effort_ratio)
        th = self.thresholds
        bad_track = ~(err <= th.tracking_rad)  # NaN counts: a position that is not measured
        bad_effort = ~(ratio <= th.effort_ratio)
        rows = np.flatnonzero(bad_track.any(axis=1) | bad_effort.any(axis=1))
        if rows.size == 0:
            return None
        k = int(rows[0])
        if bad_track[k].any():
            j = int(np.argmax(np.where(np.isfinite(err[k]), err[k], np.inf)))
            return Abort("tracking", f"tracking error of {self.joints[j]} {err[k, j]:.4g} beyond "
                                     f"{th.tracking_rad:g} (commanded {q_ref[k, j]:.4g}, measured {q[k, j]:.4g})",
                         float(t[k]))
        j = int(np.argmax(np.where(np.isfinite(ratio[k]), ratio[k], np.inf)))
        e = float(np.asarray(effort)[k, j])
        what = "not measured" if not np.isfinite(e) else f"{e:.4g}"
        return Abort("effort", f"effort of {self.joints[j]} {what} beyond {th.effort_ratio:g} × its limit "
                               f"{self.limit[j]:.4g}", float(t[k]))

    def silent(self, now: float, since: float) -> Abort | None:
        """A silence abort when no sample was received after ``now`` − ``silence_s`` (``since``: when
        the watch began, the start of the silence before the first sample) [s, the receipts' clock]."""
        last = max(self.last_rx, since) if self.last_rx is not None else since
        if now - last > self.thresholds.silence_s:
            return Abort("silence", f"joint states stopped: none for {now - last:.3g} s (limit "
                                    f"{self.thresholds.silence_s:g} s)", float(now))
        return None

    def figures(self) -> dict:
        """The worst tracking error [rad | m] and effort ratio per joint seen so far."""
        return {"max_tracking_error": dict(zip(self.joints, map(float, self.max_tracking))),
                "max_effort_ratio": dict(zip(self.joints, map(float, self.max_effort_ratio))),
                "samples": self.samples}
