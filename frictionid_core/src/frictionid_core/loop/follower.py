"""The simulated arm's position servo: what a JointTrajectoryController on a stiff robot does (no ROS import).

:class:`TrajectoryFollower` tracks a reference given as

* a trajectory (:class:`frictionid_core.experiment.Motion`, points interpolated as a
  JointTrajectoryController does with positions, velocities and accelerations), started at a time of
  the arm's clock and held at its last point after its end;
* streamed positions (a forward position controller's commands): the newest one, moved on along the
  velocity of the last two for up to one command interval (a stream's commands otherwise lag it by
  that interval);
* a hold: stay at a pose, at rest (an empty trajectory, the end of a stream, the start).

Its torque is computed-torque control on the robot's rigid-body model (armature included, no friction:
the servo does not know it): τ = M(q)·(q̈_r + ω²·(q_r − q) + 2ζω·(q̇_r − q̇)) + h(q, q̇), ω = 2π ×
``bandwidth_hz`` (default 25 Hz: a friction step at a reversal is caught within a few ms), then
clamped at each joint's effort limit, as a drive's current limit does.
"""

from __future__ import annotations

import numpy as np

SERVO_BANDWIDTH_HZ = 25.0
SERVO_DAMPING = 0.9
MAX_STREAM_GAP_S = 0.1  # streamed commands further apart than this are not extrapolated [s]


class TrajectoryFollower:
    """The servo of ``robot`` (a RobotModel), holding ``q0`` until told otherwise; ``effort_limit``
    (J,) [N·m | N] clamps its torque (default the model's limits; inf: none)."""

    def __init__(self, robot, q0, bandwidth_hz: float = SERVO_BANDWIDTH_HZ, damping: float = SERVO_DAMPING,
                 effort_limit=None):
        import pinocchio

        from frictionid_core.excitation import robot_limits

        self._pin = pinocchio
        self.robot = robot
        self._data = robot.model.createData()
        w = 2.0 * np.pi * float(bandwidth_hz)
        self.kp, self.kd = w * w, 2.0 * float(damping) * w
        limit = robot_limits(robot).effort if effort_limit is None else np.asarray(effort_limit, float)
        self.limit = np.where(np.isfinite(limit), limit, np.inf)
        self.motion = None
        self.t0 = 0.0
        self._hold = np.array(q0, dtype=float)
        self._stream: tuple | None = None  # (t, q, v, interval) of the newest streamed command
        self.mode = "hold"

    def follow(self, motion, t0: float) -> None:
        """Track ``motion`` from the arm's time ``t0`` [s]."""
        self.motion, self.t0, self._stream, self.mode = motion, float(t0), None, "trajectory"

    def stream(self, t: float, q) -> None:
        """A streamed position command ``q`` received at the arm's time ``t`` [s]."""
        q = np.array(q, dtype=float)
        prev = self._stream
        v, gap = np.zeros_like(q), 0.0
        if prev is not None and 0.0 < t - prev[0] <= MAX_STREAM_GAP_S:
            gap = t - prev[0]
            v = (q - prev[1]) / gap
        self._stream, self.motion, self.mode = (float(t), q, v, gap), None, "stream"

    def hold(self, q) -> None:
        """Stay at ``q``, at rest, from now on."""
        self._hold, self.motion, self._stream, self.mode = np.array(q, dtype=float), None, None, "hold"

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reference (q, q̇, q̈) at the arm's time ``t`` [s]."""
        if self.mode == "trajectory":
            q, qd, qdd = self.motion.at([t - self.t0])
            return q[0], qd[0], qdd[0]
        zero = np.zeros_like(self._hold)
        if self.mode == "stream":
            ts, q, v, gap = self._stream
            return q + v * min(max(t - ts, 0.0), gap), v, zero
        return self._hold.copy(), zero, zero

    def torque(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The servo's joint torque at time ``t`` [s] for the measured ``q``, ``qd``: computed torque,
        clamped at the effort limits."""
        q_r, v_r, a_r = self.reference(t)
        a = a_r + self.kp * (q_r - q) + self.kd * (v_r - qd)
        robot = self.robot
        tau = np.array(self._pin.rnea(robot.model, self._data, robot.configuration(q), np.asarray(qd, float), a))
        return np.clip(tau, -self.limit, self.limit)
