"""``frictionid_loop_controller``: a joint-group effort controller as a user of friction
feed-forward would write it (:class:`frictionid_core.loop.control.Controller`).

    frictionid_loop_controller --ros-args -p robot:=tx40 -p feedforward_enabled:=true

On every ``joint_states`` message (the task's clock starts at the first stamp) it publishes the
desired state on ``reference_topic`` (JointState with the same stamp: the frictionid node takes
the friction sign from this desired velocity) and the effort command
τ = rnea(q_d, q̇_d, q̈_d) + Kp·(q_d − q) + Kd·(q̇_d − q̇) [+ τ_friction] on
``/effort_controller/commands`` (Float64MultiArray). τ_friction is the newest message of
``feedforward_topic`` (``/frictionid/friction_torque_state``: the friction torque with the stamp
of the joint state it answers) while parameter ``feedforward_enabled`` is true. A payload on ``payload_topic``
(``/frictionid/payload``: geometry_msgs/Inertia, transient local, on the link ``payload_link``,
default the last) joins the controller's model: its rigid-body feed-forward takes it from then on.

Recorded for ``frictionid loop`` and written to ``record_file`` (.npz) at exit: per joint state
its stamp and its receipt − stamp [ns], q_d − q [rad | m], the desired velocity q̇_d, whether and
what feed-forward went out; per feed-forward message its latency = receipt − stamp of the joint state it answers [ns].
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    from geometry_msgs.msg import Inertia
    from rcl_interfaces.msg import SetParametersResult
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

from frictionid_ros.loop.loop_node import SENSOR, LoopNode, run_node

LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)

NS = 1_000_000_000
CAPACITY = 900_000  # recorded steps (15 min at 1 kHz)


class ControllerNode(LoopNode):
    """See the module docstring."""

    def __init__(self):
        super().__init__("frictionid_loop_controller")
        from frictionid_core.loop import Controller, default_trajectory, load_robot

        p = {name: self.declare_parameter(name, default).value for name, default in (
            ("robot", "tx40"), ("feedforward_enabled", False), ("joint_states_topic", "joint_states"),
            ("reference_topic", "reference_joint_states"), ("command_topic", "/effort_controller/commands"),
            ("feedforward_topic", "/frictionid/friction_torque_state"), ("record_file", ""),
            ("payload_topic", "/frictionid/payload"), ("payload_link", ""))}
        self.robot = robot = load_robot(p["robot"])
        self.payload_link = p["payload_link"] or None
        self.payload_taken_ns = 0  # when the controller took a payload [ns, wall clock]
        self.joints = list(robot.joints)
        self.ctl = Controller(robot, default_trajectory(robot))
        self.enabled = bool(p["feedforward_enabled"])
        self.record_file = p["record_file"]
        nj = len(self.joints)
        self.ff = np.zeros(nj)
        self.ff_fresh = False
        self.t0 = 0
        self.n = self.n_lat = 0
        self.stamp = np.zeros(CAPACITY, dtype=np.int64)
        self.err = np.zeros((CAPACITY, nj))
        self.v_d = np.zeros((CAPACITY, nj))
        self.ff_used = np.zeros((CAPACITY, nj))
        self.ff_on = np.zeros(CAPACITY, dtype=bool)
        self.lat = np.zeros(CAPACITY, dtype=np.int64)
        self.state_lat = np.zeros(CAPACITY, dtype=np.int64)
        self._ref = JointState(name=self.joints)
        self._cmd = Float64MultiArray()
        self._pub_ref = self.input_node.create_publisher(JointState, p["reference_topic"], SENSOR)
        self._pub_cmd = self.input_node.create_publisher(Float64MultiArray, p["command_topic"], SENSOR)
        self.input_node.create_subscription(JointState, p["joint_states_topic"], self._on_state, SENSOR)
        self.input_node.create_subscription(JointState, p["feedforward_topic"], self._on_ff, SENSOR)
        self.input_node.create_subscription(Inertia, p["payload_topic"], self._on_payload, LATCHED)
        self.add_on_set_parameters_callback(self._on_set)
        self._order = None  # index of each controller joint in the joint_states message

    def _on_set(self, params) -> SetParametersResult:
        for prm in params:
            if prm.name == "feedforward_enabled":
                self.enabled = bool(prm.value)
                self.get_logger().info(f"friction feed-forward {'on' if self.enabled else 'off'}")
        return SetParametersResult(successful=True)

    def _on_state(self, msg: JointState) -> None:
        now = time.time_ns()
        stamp = msg.header.stamp.sec * NS + msg.header.stamp.nanosec
        if self._order is None:
            self._order = [list(msg.name).index(j) for j in self.joints]
            self.t0 = stamp
        o = self._order
        q, qd = np.asarray(msg.position)[o], np.asarray(msg.velocity)[o]
        t = (stamp - self.t0) * 1e-9
        q_d, v_d, a_d = self.ctl.trajectory.at(t)
        ref = self._ref
        ref.header.stamp = msg.header.stamp
        ref.position, ref.velocity = q_d.tolist(), v_d.tolist()
        self._pub_ref.publish(ref)
        on = self.enabled and self.ff_fresh
        tau, _, _ = self.ctl.command(t, q, qd, self.ff if on else None)
        self._cmd.data = tau.tolist()
        self._pub_cmd.publish(self._cmd)
        k = self.n % CAPACITY
        self.stamp[k], self.err[k], self.ff_on[k], self.state_lat[k] = stamp, q_d - q, on, now - stamp
        self.v_d[k] = v_d
        self.ff_used[k] = self.ff if on else 0.0
        self.n += 1

    def _on_ff(self, msg: JointState) -> None:
        now = time.time_ns()
        if list(msg.name) != self.joints:
            return
        self.ff[:] = msg.effort
        self.ff_fresh = True
        self.lat[self.n_lat % CAPACITY] = now - (msg.header.stamp.sec * NS + msg.header.stamp.nanosec)
        self.n_lat += 1

    def _on_payload(self, msg: Inertia) -> None:
        """The controller's model with the payload ``msg`` (replacing any earlier one), gains kept."""
        from frictionid_core.loop import Controller
        from frictionid_core.robots import Payload, default_link, robot_with_payload

        inertia = ((msg.ixx, msg.ixy, msg.ixz), (msg.ixy, msg.iyy, msg.iyz), (msg.ixz, msg.iyz, msg.izz))
        payload = Payload(self.payload_link or default_link(self.robot), float(msg.m),
                          (msg.com.x, msg.com.y, msg.com.z), inertia)
        ctl = self.ctl
        self.ctl = Controller(robot_with_payload(self.robot, payload), ctl.trajectory, ctl.kp, ctl.kd)
        self.payload_taken_ns = time.time_ns()
        self.get_logger().info(f"rigid-body feed-forward with a {msg.m:.4g} kg payload on {payload.link}")

    def close(self) -> None:
        if not self.record_file:
            return
        n, m = min(self.n, CAPACITY), min(self.n_lat, CAPACITY)
        np.savez(self.record_file, joints=np.array(self.joints), stamp_ns=self.stamp[:n], error=self.err[:n],
                 feedforward=self.ff_used[:n], feedforward_on=self.ff_on[:n], latency_ns=self.lat[:m],
                 state_latency_ns=self.state_lat[:n], payload_taken_ns=self.payload_taken_ns,
                 desired_velocity=self.v_d[:n])


def main(argv: list[str] | None = None) -> int:
    return run_node(ControllerNode, argv)


if __name__ == "__main__":
    sys.exit(main())
