"""The ``~/run_experiment`` action on ROS 2: goals served by
:class:`frictionid_ros.experiment.ExperimentService`, feedback every 0.2 s, cancel; and the commander
through which it moves the robot.

:class:`Commander` publishes on the goal's topic (reliable, depth 100, one publisher per topic for the
node's life, so that a hold is never lost to a publisher destroyed under it):

* ``trajectory``: one ``trajectory_msgs/JointTrajectory`` per motion (header stamp = its start, every
  point with positions, velocities and accelerations), as a JointTrajectoryController takes on
  ``~/joint_trajectory``; the hold is an empty trajectory, which makes such a controller stop and hold
  its present position;
* ``position``: ``std_msgs/Float64MultiArray`` positions (the robot's joint order), as a forward position
  controller takes: the motion's positions at its start + k / rate, each sent :data:`STREAM_LEAD` command
  intervals ahead of its time (a robot plays a stream back from a buffer of about that much, which
  absorbs this process's scheduling); several at once when this process fell behind, so that the values
  stay evenly spaced in time whenever they are sent; the hold repeats the last command.
"""

from __future__ import annotations

import threading
import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, pulled in by rosidl on some versions
    from builtin_interfaces.msg import Duration, Time
    from frictionid_interfaces.action import RunExperiment
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from frictionid_ros.experiment import ExperimentService
from frictionid_ros.inputs import NS
from frictionid_ros.node.action import ServedAction
from frictionid_ros.node.messages import parameters_msg

# Reliable, and deep enough that commands sent together (this process fell behind) are not overwritten
# unacknowledged in the history: a stream's commands are played back in sequence.
COMMANDS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE)
HOLD_REPEATS = 3  # a stream's last command is sent this many times on a hold
STREAM_LEAD = 10  # a streamed command is sent this many intervals ahead of its time (the robot's buffer)


def _duration(seconds: float) -> Duration:
    ns = int(round(seconds * NS))
    return Duration(sec=ns // NS, nanosec=ns % NS)


def trajectory_msg(motion, start_ns: int) -> JointTrajectory:
    """The JointTrajectory of a :class:`frictionid_core.experiment.Motion` starting at ``start_ns``."""
    msg = JointTrajectory(joint_names=list(motion.joints))
    msg.header.stamp = Time(sec=start_ns // NS, nanosec=start_ns % NS)
    msg.points = [JointTrajectoryPoint(positions=q.tolist(), velocities=v.tolist(), accelerations=a.tolist(),
                                       time_from_start=_duration(t))
                  for t, q, v, a in zip(motion.t, motion.q, motion.qd, motion.qdd)]
    return msg


class Commander:
    """The commands of one goal on ``topic`` (``interface`` trajectory | position) for ``joints``;
    ``publisher(type, topic)`` gives the node's publisher of that topic."""

    def __init__(self, publisher, interface: str, topic: str, joints: list[str], rate_hz: float):
        self.interface, self.joints = interface, list(joints)
        self._pub = publisher(JointTrajectory if interface == "trajectory" else Float64MultiArray, topic)
        self._motion, self._start, self._k = None, 0, 0
        self._period_ns = int(round(NS / rate_hz))
        self._last = None  # the last streamed positions
        self._array = Float64MultiArray()
        self._array.layout.dim = [MultiArrayDimension(label="joints", size=len(joints), stride=len(joints))]

    def send(self, motion, start_ns: int) -> None:
        if self.interface == "trajectory":
            self._pub.publish(trajectory_msg(motion, start_ns))
        else:
            self._motion, self._start, self._k = motion, int(start_ns), 0

    def tick(self, now_ns: int) -> None:
        """A stream's commands due by ``now_ns`` (a trajectory needs none)."""
        motion = self._motion
        if motion is None:
            return
        end = int(motion.duration * NS) + self._period_ns
        while True:
            t = self._k * self._period_ns
            if t > end:  # the end point was sent: the robot holds it
                self._motion = None
                return
            if self._start + t - STREAM_LEAD * self._period_ns > now_ns:
                return
            q, _, _ = motion.at([t / NS])
            self._stream(q[0].tolist())
            self._k += 1

    def _stream(self, q: list[float]) -> None:
        self._array.data = q
        self._pub.publish(self._array)
        self._last = q

    def hold(self, q) -> None:
        """Stop and hold: an empty trajectory, or the last streamed command again (``q``, the last
        measured pose, when nothing was streamed)."""
        self._motion = None
        if self.interface == "trajectory":
            self._pub.publish(JointTrajectory(joint_names=self.joints))
            return
        last = self._last if self._last is not None else (None if q is None else list(map(float, q)))
        if last is not None:
            for _ in range(HOLD_REPEATS):
                self._stream(last)

    def close(self) -> None:
        self._motion = None


class Publishers:
    """The node's command publishers, one per (type, topic), kept for the node's life."""

    def __init__(self, node):
        self._node, self._pubs, self._lock = node, {}, threading.Lock()

    def __call__(self, msg_type, topic: str):
        with self._lock:
            pub = self._pubs.get((msg_type, topic))
            if pub is None:
                pub = self._pubs[(msg_type, topic)] = self._node.create_publisher(msg_type, topic, COMMANDS_QOS)
            return pub

    def destroy(self) -> None:
        with self._lock:
            for pub in self._pubs.values():
                self._node.destroy_publisher(pub)
            self._pubs.clear()


def experiment_service(node, settings, identify_service, active, worker, inputs, topics, publishers: Publishers,
                       log) -> ExperimentService:
    """The node's :class:`ExperimentService`, commanding through ``publishers``."""
    return ExperimentService(settings, identify_service, active, worker, inputs, topics,
                             lambda interface, topic, joints, rate_hz: Commander(publishers, interface, topic, joints,
                                                                                 rate_hz),
                             serialize_message, log)


def experiment_action(node, service: ExperimentService, joints, log, callback_group) -> ServedAction:
    """``~/run_experiment``: served by ``service``; ``joints()``: the node's joint order for the result."""

    def feedback(control, elapsed_s: float):
        st = service.status
        return RunExperiment.Feedback(phase=st.phase, progress=float(st.progress),
                                      tracking_error=float(st.tracking_error) if st.tracking_error == st.tracking_error
                                      else 0.0, max_effort_ratio=float(st.max_effort_ratio), elapsed_s=elapsed_s)

    def fill(result, answer) -> None:
        result.accepted, result.applied, result.aborted = answer.accepted, answer.applied, answer.aborted
        result.abort_reason, result.reason, result.bag = answer.abort_reason, answer.reason, answer.bag
        result.result_file = answer.result_file
        result.validation_relerr_pct = float(answer.validation.get("relerr_pct", float("nan")))
        result.validation_noise_floor_pct = float(answer.validation.get("noise_floor_pct", float("nan")))
        if answer.identified is not None:
            result.result = parameters_msg(answer.identified, joints())
        result.json = answer.json()

    return ServedAction(node, RunExperiment, "~/run_experiment", service.handle, feedback, fill, log, callback_group)
