"""The simulated arm's position servo: what a JointTrajectoryController on a stiff robot does (no ROS import).

:class:`TrajectoryFollower` tracks a reference given as

* a trajectory (:class:`frictionid_core.experiment.Motion`, points interpolated as a
  JointTrajectoryController does with positions, velocities and accelerations), started at a time of
  the arm's clock and held at its last point after its end;
* streamed positions (a forward position controller's commands, sent at ``stream_rate_hz``): played
  back as a robot's streaming interface does, from a buffer: command k at the time of the earliest
  receipt of any command j, less j intervals, + (:data:`STREAM_BUFFER` + k) command intervals (the
  sender's schedule as best seen; a better estimate is taken by playing :data:`STREAM_SLEW` faster
  until it is reached, never by a jump), Catmull-Rom splines between them (smooth; straight on beyond
  the newest command
  position and velocity), so that commands arriving unevenly (a sender's scheduling) or together do not
  jerk the arm; a stream that runs dry goes on along its last velocity (its late commands then take over
  where they belong: no jump), and holds its last command after :data:`MAX_STREAM_GAP_S`; one that
  pauses longer than that starts over;
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
MAX_STREAM_GAP_S = 0.1  # a stream pausing longer starts over [s]
STREAM_BUFFER = 10  # a stream is played back this many command intervals after its first command's receipt
STREAM_RATE_HZ = 250.0
STREAM_SLEW = 0.05  # a stream's playback catches up with a better estimate of its schedule this much faster


class TrajectoryFollower:
    """The servo of ``robot`` (a RobotModel), holding ``q0`` until told otherwise; ``effort_limit``
    (J,) [N·m | N] clamps its torque (default the model's limits; inf: none); ``stream_rate_hz``: the
    rate of streamed commands."""

    def __init__(self, robot, q0, bandwidth_hz: float = SERVO_BANDWIDTH_HZ, damping: float = SERVO_DAMPING,
                 effort_limit=None, stream_rate_hz: float = STREAM_RATE_HZ):
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
        self.period = 1.0 / float(stream_rate_hz)
        self._queue: list[np.ndarray] = []  # the stream's commands from number _first on
        self._first = 0
        self._play0 = self._target0 = self._last_rx = -np.inf  # command 0's playback time (and the best estimate
        # of it), the newest receipt [s]
        self._t_played = 0.0  # the time the playback was last evaluated [s]
        self.mode = "hold"

    def follow(self, motion, t0: float) -> None:
        """Track ``motion`` from the arm's time ``t0`` [s]."""
        self.motion, self.t0, self.mode = motion, float(t0), "trajectory"

    def stream(self, t: float, q) -> None:
        """A streamed position command ``q`` received at the arm's time ``t`` [s]."""
        q = np.array(q, dtype=float)
        if self.mode != "stream" or t - self._last_rx > MAX_STREAM_GAP_S:  # a new stream
            self._queue, self._first = [q], 0
            self._play0 = self._target0 = t + STREAM_BUFFER * self.period
            self._t_played = t
        else:
            self._queue.append(q)
            k = self._first + len(self._queue) - 1
            self._target0 = min(self._target0, t + (STREAM_BUFFER - k) * self.period)
        self._last_rx, self.motion, self.mode = t, None, "stream"

    def hold(self, q) -> None:
        """Stay at ``q``, at rest, from now on."""
        self._hold, self.motion, self.mode = np.array(q, dtype=float), None, "hold"

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reference (q, q̇, q̈) at the arm's time ``t`` [s]."""
        if self.mode == "trajectory":
            q, qd, qdd = self.motion.at([t - self.t0])
            return q[0], qd[0], qdd[0]
        zero = np.zeros_like(self._hold)
        if self.mode == "stream":
            return self._played(t)
        return self._hold.copy(), zero, zero

    def _played(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stream's reference at ``t``: Catmull-Rom between the commands around it."""
        queue, h = self._queue, self.period
        if self._play0 > self._target0:  # catching up, STREAM_SLEW faster
            self._play0 = max(self._target0, self._play0 - STREAM_SLEW * max(t - self._t_played, 0.0))
        self._t_played = t
        x = (t - self._play0) / h - self._first  # position in the queue
        k = int(np.floor(x))
        drop = min(k - 2, len(queue) - 2)  # commands played long ago (the last two stay)
        if drop > 0:
            del queue[:drop]
            self._first += drop
            x -= drop
            k -= drop
        n = len(queue)
        zero = np.zeros_like(queue[0])
        if x <= 0.0:
            return queue[0].copy(), zero, zero
        if k >= n - 1:  # ran dry: on along the last velocity for a while, then the last command at rest
            dry = (x - (n - 1)) * h
            if n < 2 or dry > MAX_STREAM_GAP_S:
                return queue[-1].copy(), zero, zero
            v = (queue[-1] - queue[-2]) / h
            return queue[-1] + v * dry, v, zero
        p1, p2 = queue[k], queue[k + 1]
        p0 = queue[k - 1] if k >= 1 else 2.0 * p1 - p2  # beyond the ends: straight on (no kink)
        p3 = queue[k + 2] if k + 2 < n else 2.0 * p2 - p1
        u = x - k
        c1, c2, c3 = 0.5 * (p2 - p0), p0 - 2.5 * p1 + 2.0 * p2 - 0.5 * p3, 0.5 * (p3 - p0) + 1.5 * (p1 - p2)
        q = p1 + u * (c1 + u * (c2 + u * c3))
        return q, (c1 + u * (2.0 * c2 + 3.0 * u * c3)) / h, (2.0 * c2 + 6.0 * u * c3) / (h * h)

    def torque(self, t: float, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The servo's joint torque at time ``t`` [s] for the measured ``q``, ``qd``: computed torque,
        clamped at the effort limits."""
        q_r, v_r, a_r = self.reference(t)
        a = a_r + self.kp * (q_r - q) + self.kd * (v_r - qd)
        robot = self.robot
        tau = np.array(self._pin.rnea(robot.model, self._data, robot.configuration(q), np.asarray(qd, float), a))
        return np.clip(tau, -self.limit, self.limit)
