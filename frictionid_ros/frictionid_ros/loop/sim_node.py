"""``frictionid_sim``: a MuJoCo-simulated arm with hidden friction, driven over ROS 2 like a
ros2_control robot (:class:`frictionid_core.loop.sim.SimArm`).

    frictionid_sim --ros-args -p robot:=tx40

Publishes ``joint_states`` (sensor_msgs/JointState, sensor-data QoS) every step at ``rate_hz``:
position, velocity, effort = the torque applied during the step [N·m | N], stamp = the simulated
clock (wall clock at its start + simulated time: regular 1 ms steps, as a robot's clock). Takes
``/effort_controller/commands`` (std_msgs/Float64MultiArray, joint order of ``joint_states``), held
until the next one; the arm stands still until the first command.
Parameter ``drift_start`` (set to true at runtime) starts the Coulomb drift: +``drift_fraction``
of Fc and Fs over ``drift_s`` seconds; ``payload_kg`` (set > 0 at runtime) fixes the loop's payload
of that mass to the last link (:func:`frictionid_core.loop.loop_payload`) before the next step.
Steps run in a thread of their own at absolute times.
"""

from __future__ import annotations

import sys
import threading
import time
import warnings

import numpy as np

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    from rcl_interfaces.msg import SetParametersResult
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

from frictionid_core import FrictionIdError
from frictionid_ros.loop.loop_node import SENSOR, LoopNode, run_node

CATCH_UP_S = 0.05  # a step later than this restarts the schedule instead of racing to catch up [s]


class SimNode(LoopNode):
    """See the module docstring."""

    def __init__(self):
        super().__init__("frictionid_sim")
        from frictionid_core.loop import SimArm, default_trajectory, hidden_friction, load_robot

        p = {name: self.declare_parameter(name, default).value for name, default in (
            ("robot", "tx40"), ("rate_hz", 1000.0), ("drift_fraction", 0.3), ("drift_s", 60.0),
            ("drift_start", False), ("payload_kg", 0.0), ("joint_states_topic", "joint_states"),
            ("command_topic", "/effort_controller/commands"), ("hidden_friction", "stribeck"))}
        self.robot = robot = load_robot(p["robot"])
        self.sim = SimArm(robot, hidden_friction(p["robot"], robot.joints), q0=default_trajectory(robot).q0,
                          law=p["hidden_friction"])
        self.period = 1.0 / float(p["rate_hz"])
        if abs(self.period - self.sim.model.opt.timestep) > 1e-12:
            raise FrictionIdError(f"rate_hz must be {1.0 / self.sim.model.opt.timestep:g} (the simulation step)")
        self._drift = (float(p["drift_fraction"]), float(p["drift_s"]))
        self.command = None  # latest command (J,), None before the first
        self._attach = None  # a payload to fix to the arm before the next step
        self.commands = self.rejected = 0
        self._pub = self.input_node.create_publisher(JointState, p["joint_states_topic"], SENSOR)
        self.input_node.create_subscription(Float64MultiArray, p["command_topic"], self._on_command, SENSOR)
        self.add_on_set_parameters_callback(self._on_set)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="frictionid-sim", daemon=True)
        self._thread.start()
        self.get_logger().info(f"simulating {robot.name} ({robot.nv} joints) at {p['rate_hz']:g} Hz")

    def _on_set(self, params) -> SetParametersResult:
        for prm in params:
            if prm.name == "drift_start" and prm.value:
                self.sim.start_drift(*self._drift)
                self.get_logger().info(f"Coulomb drift started: +{100 * self._drift[0]:g} % over {self._drift[1]:g} s")
            elif prm.name == "payload_kg" and prm.value > 0:
                from frictionid_core.loop import loop_payload

                try:
                    self._attach = loop_payload(self.robot, float(prm.value))
                except FrictionIdError as exc:
                    return SetParametersResult(successful=False, reason=str(exc))
                self.get_logger().info(f"payload of {prm.value:g} kg attached to {self._attach.link}")
        return SetParametersResult(successful=True)

    def _on_command(self, msg: Float64MultiArray) -> None:
        if len(msg.data) != self.robot.nv:
            self.rejected += 1
            return
        self.command = np.array(msg.data, dtype=float)
        self.commands += 1

    def _loop(self) -> None:
        """Step at absolute times; stamp = the simulated clock (wall clock of the first step's
        scheduled time + sim time: a message never leaves before its stamp), regular like a robot's; a step
        later than CATCH_UP_S shifts that clock instead of racing (the data then shows a gap of that length)."""
        msg = JointState(name=list(self.robot.joints))
        sim, period = self.sim, self.period
        nxt = time.monotonic()
        origin = 0  # wall clock of sim time 0 [ns]
        while not self._stop.is_set():
            nxt += period
            delay = nxt - time.monotonic()
            if delay > 0.0:
                time.sleep(delay)
            elif delay < -CATCH_UP_S:
                nxt -= delay
                origin -= int(delay * 1e9)
            if self._attach is not None:
                sim.attach_payload(self._attach)
                self._attach = None
            cmd = self.command
            if cmd is None:  # standing still: the clock follows the wall clock of the scheduled ticks
                origin = time.time_ns() - round((time.monotonic() - nxt) * 1e9) - round(sim.t * 1e9)
            else:
                sim.step(cmd)
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(origin + round(sim.t * 1e9), 1_000_000_000)
            msg.position = sim.data.qpos.tolist()
            msg.velocity = sim.data.qvel.tolist()
            msg.effort = sim.tau.tolist()
            try:
                self._pub.publish(msg)
            except Exception:  # the context is shutting down
                return

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)


def main(argv: list[str] | None = None) -> int:
    return run_node(SimNode, argv)


if __name__ == "__main__":
    sys.exit(main())
