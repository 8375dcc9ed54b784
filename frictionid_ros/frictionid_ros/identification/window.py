"""The data window of an identification: buffered rows → a checked JointSeries (no ROS import)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from frictionid_core import InputError, JointSeries
from frictionid_core.io import MIN_SAMPLES, align_effort, check_series, stamp_gaps
from frictionid_ros.identification.request import Job
from frictionid_ros.inputs import NO_EFFORT, NO_POSITION, NO_VELOCITY, NS, JointRing
from frictionid_ros.parameters import Config


@dataclass
class Selection:
    """A window ready to identify: ``series`` (``t`` [s] from the window's first buffered stamp),
    the stamps of its first and last samples [ns since the epoch] and notes on what was done to
    the data (effort alignment, stamp repairs, lost samples)."""

    series: JointSeries
    start_ns: int
    end_ns: int
    notes: list[str]


def window_series(job: Job, cfg: Config, ring: JointRing | None, topic: str,
                  effort_ring: JointRing | None = None, effort_topic: str = "") -> Selection:
    """The rows of ``ring`` the job asks for, with the effort of ``effort_ring`` if given
    (interpolated at the header stamps, or at the receipt times when ``cfg.effort_topic_type``
    is an unstamped Float64MultiArray). Raises InputError naming the problem: too little data,
    empty fields, NaN samples, more lost samples than ``cfg.max_missing_pct``."""
    need = max(cfg.min_samples, MIN_SAMPLES)
    if ring is None or ring.count == 0:
        raise InputError(f"too little data: no joint states buffered on '{topic}' (need at least {cfg.min_samples})")
    w = ring.snapshot()
    t = w.t_ns
    if job.start_ns or job.end_ns:
        keep = (t >= job.start_ns) & ((t <= job.end_ns) if job.end_ns else True)
        what = "in window_start..window_end"
    else:
        span = job.window_seconds or min(cfg.buffer_seconds, cfg.max_window_seconds)
        keep = t >= t.max() - int(span * NS)
        what = f"in the last {span:g} s"
    w = w.take(keep)
    n = len(w)
    span = (int(w.t_ns.max()) - int(w.t_ns.min())) / NS if n else 0.0
    if span > cfg.max_window_seconds:
        raise InputError(f"window of {span:g} s {what} is over the limit max_window_seconds = "
                         f"{cfg.max_window_seconds:g} s")
    if n < need:
        raise InputError(f"too little data: {n} joint-state samples {what} (need at least {cfg.min_samples}); "
                         f"{ring.count} buffered")
    missing = int(np.count_nonzero(w.flags & NO_POSITION))
    if missing:
        raise InputError(f"field 'position' is empty or shorter than 'name' in {missing} of {n} "
                         f"joint_states messages {what}")
    missing = int(np.count_nonzero(w.flags & NO_EFFORT))
    if missing and effort_ring is None:
        raise InputError(f"empty effort: field 'effort' is empty or shorter than 'name' in {missing} of {n} "
                         f"joint_states messages {what}; publish effort in the JointState or set the parameter "
                         "'effort_topic'")
    origin = int(w.t_ns.min())
    series = JointSeries(t=(w.t_ns - origin) * 1e-9, joints=list(ring.joints), position=w.position, effort=w.effort,
                         velocity=None if np.any(w.flags & NO_VELOCITY) else w.velocity,
                         source=f"{topic} ({n} samples {what})")
    if effort_ring is not None:
        series = _with_effort(series, w, cfg, effort_ring, effort_topic, need)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the repairs are in series.notes
        series = check_series(series.select(job.joints))
    notes = list(series.notes)
    gaps = stamp_gaps(series)
    if gaps.gaps:
        if gaps.missing_pct > cfg.max_missing_pct:
            raise InputError(f"gaps in the stamps of the joint states {what}: {gaps}, more than max_missing_pct = "
                             f"{cfg.max_missing_pct:g} %; check the input QoS (qos, qos_depth) and the publisher's "
                             "timing")
        notes.append(f"joint states {what}: {gaps}")
    return Selection(series, origin + round(series.t[0] * NS), origin + round(series.t[-1] * NS), notes)


def _with_effort(series: JointSeries, w, cfg: Config, effort_ring: JointRing, topic: str, need: int) -> JointSeries:
    """``series`` with the separate effort topic interpolated at its header stamps, or at the receipt
    times ``w.rx_ns`` for an unstamped Float64MultiArray topic (same clock as the effort's receipt)."""
    e = effort_ring.snapshot()
    if len(e) == 0:
        raise InputError(f"empty effort: nothing received on the effort topic '{topic}'")
    bad = int(np.count_nonzero(e.flags & NO_EFFORT))
    if bad:
        raise InputError(f"empty effort: field 'effort' is empty or short in {bad} messages on '{topic}'")
    at = w.t_ns if cfg.effort_topic_type == "joint_state" else w.rx_ns
    origin = int(e.t_ns.min())
    return align_effort(series, (e.t_ns - origin) * 1e-9, e.effort, f"effort topic '{topic}'",
                        at=(at - origin) * 1e-9, min_samples=need)
