"""A commanded joint motion as trajectory points (no ROS import).

A :class:`Motion` is what a controller is sent: points (times from its start, and per joint the
position, velocity and acceleration at each), the way a ``trajectory_msgs/JointTrajectory`` carries
them. Between points it is the quintic Hermite curve through both ends' position, velocity and
acceleration — what a JointTrajectoryController interpolates with all three given — so sampling a
smooth trajectory every 10 ms and interpolating it again is exact to ~1e-9 rad. Before its start it
is at its first point, after its end at its last.

The robot reaches an experiment's start pose by :func:`approach`: a quintic (rest to rest) in joint
space, long enough that every joint stays within ``speed`` × its velocity and acceleration limits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import InputError

POINT_RATE_HZ = 100.0  # default: trajectory points per second of a sampled trajectory
MIN_APPROACH_S = 1.0  # an approach never takes less [s]
# A quintic rest-to-rest move of Δ in T: peak velocity 15/8·Δ/T, peak acceleration 10/√3·Δ/T².
QUINTIC_PEAK_VELOCITY = 15.0 / 8.0
QUINTIC_PEAK_ACCELERATION = 10.0 / np.sqrt(3.0)


def quintic(p0, v0, a0, p1, v1, a1, h, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration at the fraction ``s`` ∈ [0, 1] of a segment of length ``h``
    [s] between (p0, v0, a0) and (p1, v1, a1) (arrays broadcast): the quintic Hermite curve."""
    dp = p1 - p0
    c1, c2 = v0 * h, 0.5 * a0 * h * h
    w1, w2 = v1 * h, a1 * h * h
    c3 = 10.0 * dp - 6.0 * c1 - 4.0 * w1 - 3.0 * c2 + 0.5 * w2
    c4 = -15.0 * dp + 8.0 * c1 + 7.0 * w1 + 3.0 * c2 - w2
    c5 = 6.0 * dp - 3.0 * c1 - 3.0 * w1 - c2 + 0.5 * w2
    q = p0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
    dq = c1 + s * (2.0 * c2 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5)))
    ddq = 2.0 * c2 + s * (6.0 * c3 + s * (12.0 * c4 + s * 20.0 * c5))
    return q, dq / h, ddq / (h * h)


@dataclass
class Motion:
    """Trajectory points of ``joints``: times ``t`` (P,) [s] from the motion's start, strictly
    increasing from 0, and ``q``, ``qd``, ``qdd`` (P, J) [rad, rad/s, rad/s² | m, m/s, m/s²]."""

    joints: list[str]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float)
        self.q, self.qd, self.qdd = (np.asarray(a, dtype=float).reshape(len(self.t), len(self.joints))
                                     for a in (self.q, self.qd, self.qdd))
        if len(self.t) < 1 or self.t[0] != 0.0 or np.any(np.diff(self.t) <= 0):
            raise InputError("a motion's point times must start at 0 and increase")
        if not all(np.all(np.isfinite(a)) for a in (self.q, self.qd, self.qdd)):
            raise InputError("a motion has NaN or infinite points")

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    @property
    def start(self) -> np.ndarray:
        return self.q[0].copy()

    @property
    def end(self) -> np.ndarray:
        return self.q[-1].copy()

    def at(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q̇, q̈ at times ``t`` (N,) [s from the start], each (N, J): at rest at the first point
        before the start and at the last after the end (with their velocities and accelerations)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if len(self.t) == 1:
            return (np.tile(a[0], (len(t), 1)) for a in (self.q, self.qd, self.qdd))
        tc = np.clip(t, 0.0, self.t[-1])
        k = np.clip(np.searchsorted(self.t, tc, side="right") - 1, 0, len(self.t) - 2)
        h = (self.t[k + 1] - self.t[k])[:, None]
        s = ((tc - self.t[k]) / h[:, 0])[:, None]
        q, qd, qdd = quintic(self.q[k], self.qd[k], self.qdd[k], self.q[k + 1], self.qd[k + 1], self.qdd[k + 1], h, s)
        outside = ((t < 0.0) | (t > self.t[-1]))[:, None]
        if outside.any():  # at rest at the end it is held at: no velocity, no acceleration beyond the motion
            qd = np.where(outside, np.where((t < 0.0)[:, None], self.qd[0], self.qd[-1]), qd)
            qdd = np.where(outside, np.where((t < 0.0)[:, None], self.qdd[0], self.qdd[-1]), qdd)
        return q, qd, qdd

    def sample(self, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(t, q, q̇, q̈) every 1/``rate`` s over the motion (and its last point): what
        :func:`frictionid_core.excitation.verify` checks."""
        t = np.arange(int(np.floor(self.duration * rate + 1e-9)) + 1) / rate
        if t[-1] < self.duration:
            t = np.append(t, self.duration)
        return (t, *self.at(t))

    def then(self, other: Motion) -> Motion:
        """This motion followed by ``other`` (which starts where this one ends)."""
        if other.joints != self.joints:
            raise InputError(f"joints {other.joints} do not follow {self.joints}")
        t = np.concatenate([self.t, self.duration + other.t[1:]])
        return Motion(self.joints, t, *(np.vstack([a, b[1:]]) for a, b in
                                        ((self.q, other.q), (self.qd, other.qd), (self.qdd, other.qdd))))

    def to_dict(self) -> dict:
        return {"joints": list(self.joints), "t": self.t.tolist(), "q": self.q.tolist(), "qd": self.qd.tolist(),
                "qdd": self.qdd.tolist()}


def sampled(trajectory, joints: list[str], rate: float = POINT_RATE_HZ) -> Motion:
    """The points of a trajectory (anything with ``joints`` and ``sample(rate)``, such as a
    :class:`~frictionid_core.excitation.design.FourierTrajectory` of ``frictionid excite``) every
    1/``rate`` s, its joints put in the order ``joints`` (each must be one of them)."""
    missing = [j for j in joints if j not in trajectory.joints]
    if missing:
        raise InputError(f"the trajectory has no joint(s) {missing} (it has {list(trajectory.joints)})")
    t, q, qd, qdd = trajectory.sample(rate)
    order = [list(trajectory.joints).index(j) for j in joints]
    return Motion(list(joints), t - t[0], q[:, order], qd[:, order], qdd[:, order])


def approach_duration(q_from: np.ndarray, q_to: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray,
                      speed: float) -> float:
    """The length [s] of a quintic rest-to-rest move from ``q_from`` to ``q_to`` whose peak speed and
    acceleration stay within ``speed`` × each joint's limits (infinite limits ignored), at least
    :data:`MIN_APPROACH_S`."""
    if not (np.isfinite(speed) and 0.0 < speed <= 1.0):
        raise InputError(f"the approach speed must be a fraction in (0, 1] of the limits, got {speed:g}")
    dq = np.abs(np.asarray(q_to, float) - np.asarray(q_from, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = np.where(np.isfinite(velocity), QUINTIC_PEAK_VELOCITY * dq / (speed * velocity), 0.0)
        ta = np.where(np.isfinite(acceleration), np.sqrt(QUINTIC_PEAK_ACCELERATION * dq / (speed * acceleration)), 0.0)
    return float(max(MIN_APPROACH_S, np.max(tv, initial=0.0), np.max(ta, initial=0.0)))


def approach(joints: list[str], q_from: np.ndarray, q_to: np.ndarray, duration: float,
             rate: float = POINT_RATE_HZ) -> Motion:
    """A quintic rest-to-rest move from ``q_from`` to ``q_to`` in ``duration`` s, as points every
    1/``rate`` s."""
    n = max(2, int(np.ceil(duration * rate)) + 1)
    t = np.linspace(0.0, duration, n)
    s = (t / duration)[:, None]
    q0, q1 = np.asarray(q_from, float)[None], np.asarray(q_to, float)[None]
    zero = np.zeros_like(q0)
    q, qd, qdd = quintic(q0, zero, zero, q1, zero, zero, duration, s)
    return Motion(list(joints), t, q, qd, qdd)
