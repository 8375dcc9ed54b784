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

``command_interface: position`` makes it a position-controlled robot instead (``frictionid
experiment``): its servo (:class:`frictionid_core.loop.TrajectoryFollower`, in the step loop) holds the
start pose ``q0`` and follows ``trajectory_msgs/JointTrajectory`` on ``trajectory_topic`` (header stamp =
the start, 0: at once; an empty one: stop and hold here) and streamed ``std_msgs/Float64MultiArray``
positions on ``position_topic`` (sent at ``stream_rate_hz``, played back from a buffer); effort = the
servo's torque. ``position_noise`` [rad | m] and
``effort_noise`` [N·m | N] add white noise to what is published (not to what the servo sees).
Faults, set at runtime with ``fault`` on joint ``fault_joint``: ``tracking`` (the joint blocked from then
on, as by a brake that drags: a dry friction of twice its effort limit, MuJoCo's soft constraint, stops it
within a few ms; its drive folds its torque back to half its effort limit, as a drive's stall protection
does), ``effort`` (its drive's torque jumps to 1.5 × its effort limit for 50 ms),
``silence`` (no joint state published for ``fault_s``); an empty ``fault`` clears it. With
``record_file`` the true state of every step (stamp, q, q̇, torque), the fault's start and when each hold
came are written to that .npz at exit.
"""

from __future__ import annotations

import collections
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
    from trajectory_msgs.msg import JointTrajectory

from frictionid_core import FrictionIdError
from frictionid_ros.loop.loop_node import SENSOR, LoopNode, run_node

CATCH_UP_S = 0.05  # a step later than this restarts the schedule instead of racing to catch up [s]
FAULTS = ("tracking", "effort", "silence")
EFFORT_SPIKE = (1.5, 0.05)  # the effort fault: × the effort limit, for this long [s]
STALL_FOLDBACK = 0.5  # the tracking fault: a blocked joint's drive torque, × its effort limit
BLOCK = 2.0  # the tracking fault: the blocking dry friction, × the joint's effort limit
RECORD_CAPACITY = 600_000  # steps kept by record_file (10 min at 1 kHz)
NS = 1_000_000_000


class SimNode(LoopNode):
    """See the module docstring."""

    def __init__(self):
        super().__init__("frictionid_sim")
        from frictionid_core.loop import SimArm, default_trajectory, hidden_friction, load_robot

        p = {name: self.declare_parameter(name, default).value for name, default in (
            ("robot", "tx40"), ("rate_hz", 1000.0), ("drift_fraction", 0.3), ("drift_s", 60.0),
            ("drift_start", False), ("payload_kg", 0.0), ("joint_states_topic", "joint_states"),
            ("command_topic", "/effort_controller/commands"), ("hidden_friction", "stribeck"),
            ("command_interface", "effort"), ("trajectory_topic", "/joint_trajectory_controller/joint_trajectory"),
            ("position_topic", "/forward_position_controller/commands"), ("q0", [0.0]),
            ("position_noise", 0.0), ("effort_noise", 0.0), ("noise_seed", 0), ("fault", ""), ("fault_joint", 0),
            ("fault_s", 1.5), ("record_file", ""), ("stream_rate_hz", 250.0))}
        self.robot = robot = load_robot(p["robot"])
        q0 = np.array(p["q0"], dtype=float) if len(p["q0"]) == robot.nv else default_trajectory(robot).q0
        self.sim = SimArm(robot, hidden_friction(p["robot"], robot.joints), q0=q0, law=p["hidden_friction"],
                          guard_reversals=p["command_interface"] == "position")  # a stiff servo
        if p["command_interface"] not in ("effort", "position"):
            raise FrictionIdError(f"command_interface must be effort or position, got {p['command_interface']!r}")
        self.follower = None
        self._servo_commands: collections.deque = collections.deque()  # from the callbacks to the step loop
        if p["command_interface"] == "position":
            from frictionid_core.loop import TrajectoryFollower

            self.follower = TrajectoryFollower(robot, q0, stream_rate_hz=float(p["stream_rate_hz"]))
        self._noise = (float(p["position_noise"]), float(p["effort_noise"]), np.random.default_rng(p["noise_seed"]))
        self._fault_joint, self._fault_s = int(p["fault_joint"]), float(p["fault_s"])
        if not 0 <= self._fault_joint < robot.nv:
            raise FrictionIdError(f"fault_joint must be 0..{robot.nv - 1}, got {self._fault_joint}")
        self.fault, self.fault_ns, self._fault_state = "", 0, None
        self.hold_ns: list[int] = []  # when the servo took each hold (stop) command [ns, the arm's clock]
        self.record_file = p["record_file"]
        if self.record_file:
            self._rec = {"stamp_ns": np.zeros(RECORD_CAPACITY, np.int64),
                         **{k: np.zeros((RECORD_CAPACITY, robot.nv), np.float32) for k in ("q", "qd", "tau")}}
        self._n_rec = 0
        self._origin = 0  # wall clock of sim time 0 [ns]
        self.period = 1.0 / float(p["rate_hz"])
        if abs(self.period - self.sim.model.opt.timestep) > 1e-12:
            raise FrictionIdError(f"rate_hz must be {1.0 / self.sim.model.opt.timestep:g} (the simulation step)")
        self._drift = (float(p["drift_fraction"]), float(p["drift_s"]))
        self.command = None  # latest command (J,), None before the first
        self._attach = None  # a payload to fix to the arm before the next step
        self.commands = self.rejected = 0
        self._pub = self.input_node.create_publisher(JointState, p["joint_states_topic"], SENSOR)
        if self.follower is None:
            self.input_node.create_subscription(Float64MultiArray, p["command_topic"], self._on_command, SENSOR)
        else:  # what a JointTrajectoryController and a forward position controller listen to (reliable; a stream
            # is played back in sequence: deep enough to lose none of a burst)
            self.input_node.create_subscription(JointTrajectory, p["trajectory_topic"], self._on_trajectory, 10)
            self.input_node.create_subscription(Float64MultiArray, p["position_topic"], self._on_position, 100)
        self.add_on_set_parameters_callback(self._on_set)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="frictionid-sim", daemon=True)
        self._thread.start()
        self.get_logger().info(f"simulating {robot.name} ({robot.nv} joints) at {p['rate_hz']:g} Hz, "
                               f"{p['command_interface']} commands")

    def _on_set(self, params) -> SetParametersResult:
        for prm in params:
            if prm.name == "fault":
                if (prm.value and prm.value not in FAULTS) or self.follower is None:
                    return SetParametersResult(successful=False, reason=f"fault: one of {', '.join(FAULTS)} (empty: "
                                                                        "none), with command_interface position")
                self._servo_commands.append(("fault", prm.value))
                self.get_logger().info(f"fault {prm.value} on {self.robot.joints[self._fault_joint]}" if prm.value
                                       else "fault cleared")
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

    def _on_trajectory(self, msg: JointTrajectory) -> None:
        """A JointTrajectoryController's command, for the step loop: (stamp [ns, 0: at once], motion or
        None: stop and hold)."""
        stamp = msg.header.stamp.sec * NS + msg.header.stamp.nanosec
        if not msg.points:
            self._servo_commands.append(("hold", None))
            return
        order = [list(msg.joint_names).index(j) for j in self.robot.joints] if list(msg.joint_names) != list(
            self.robot.joints) else None
        try:
            t = np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in msg.points])
            arrays = [np.array([getattr(p, f) for p in msg.points], dtype=float).reshape(len(t), -1)
                      for f in ("positions", "velocities", "accelerations")]
            if order is not None:
                arrays = [a[:, order] for a in arrays]
            self._servo_commands.append(("trajectory", stamp, t, *arrays))
        except (ValueError, IndexError):
            self.rejected += 1

    def _on_position(self, msg: Float64MultiArray) -> None:
        if len(msg.data) != self.robot.nv:
            self.rejected += 1
            return
        self._servo_commands.append(("position", np.array(msg.data, dtype=float)))
        self.commands += 1

    def _servo(self) -> np.ndarray:
        """The servo's torque for this step, after the commands that came since the last one."""
        from frictionid_core.experiment import Motion

        sim, f, queue = self.sim, self.follower, self._servo_commands
        while queue:
            cmd = queue.popleft()
            kind = cmd[0]
            if kind == "hold":
                f.hold(sim.q)
                self.hold_ns.append(self._origin + round(sim.t * 1e9))
            elif kind == "position":
                f.stream(sim.t, cmd[1])
            elif kind == "fault":
                k = self._fault_joint
                if cmd[1]:
                    self.fault_ns = self._origin + round(sim.t * 1e9)
                    self._fault_state = {"tracking": None, "effort": sim.t + EFFORT_SPIKE[1],
                                         "silence": sim.t + self._fault_s}[cmd[1]]
                # the blocked joint: a dry friction of BLOCK × its effort limit (MuJoCo's, a soft constraint)
                sim.model.dof_frictionloss[k] = BLOCK * f.limit[k] if cmd[1] == "tracking" else 0.0
                self.fault = cmd[1]
            else:
                _, stamp, t, q, qd, qdd = cmd
                t0 = (stamp - self._origin) / 1e9 if stamp else sim.t
                if t[0] > 0.0:  # from where the servo is now to the first point, as a JTC does
                    r = f.reference(t0)
                    q, qd, qdd = (np.vstack([a[None], b]) for a, b in zip(r, (q, qd, qdd)))
                    t = np.concatenate([[0.0], t])
                try:
                    f.follow(Motion(list(self.robot.joints), t, q, qd, qdd), t0)
                except FrictionIdError:
                    self.rejected += 1
        tau = f.torque(sim.t, sim.q, sim.qd)
        k = self._fault_joint
        if self.fault == "effort" and sim.t < self._fault_state:
            tau[k] = EFFORT_SPIKE[0] * f.limit[k] * (1.0 if tau[k] >= 0 else -1.0)
        elif self.fault == "tracking":
            tau[k] = np.clip(tau[k], -STALL_FOLDBACK * f.limit[k], STALL_FOLDBACK * f.limit[k])
        return tau

    def _loop(self) -> None:
        """Step at absolute times; stamp = the simulated clock (wall clock of the first step's
        scheduled time + sim time: a message never leaves before its stamp), regular like a robot's; a step
        later than CATCH_UP_S shifts that clock instead of racing (the data then shows a gap of that length).
        A position-controlled arm keeps its clock instead, as a robot's controller does: its trajectories are
        in that clock, whose stamps then lag the wall clock by the stalls."""
        msg = JointState(name=list(self.robot.joints))
        sim, period = self.sim, self.period
        sigma_q, sigma_e, rng = self._noise
        nv = self.robot.nv
        nxt = time.monotonic()
        self._origin = time.time_ns() - round(sim.t * 1e9)  # wall clock of sim time 0 [ns]
        while not self._stop.is_set():
            nxt += period
            delay = nxt - time.monotonic()
            if delay > 0.0:
                time.sleep(delay)
            elif delay < -CATCH_UP_S:
                nxt -= delay
                if self.follower is None:
                    self._origin -= int(delay * 1e9)
            if self._attach is not None:
                sim.attach_payload(self._attach)
                self._attach = None
            cmd = self.command if self.follower is None else self._servo()
            if cmd is None:  # standing still: the clock follows the wall clock of the scheduled ticks
                self._origin = time.time_ns() - round((time.monotonic() - nxt) * 1e9) - round(sim.t * 1e9)
            else:
                sim.step(cmd)
            stamp = self._origin + round(sim.t * 1e9)
            if self.record_file and self._n_rec < RECORD_CAPACITY:
                r, n = self._rec, self._n_rec
                r["stamp_ns"][n], r["q"][n], r["qd"][n], r["tau"][n] = stamp, sim.data.qpos, sim.data.qvel, sim.tau
                self._n_rec += 1
            if self.fault == "silence" and sim.t < self._fault_state:
                continue
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, NS)
            q, tau = sim.data.qpos, sim.tau
            if sigma_q > 0:
                q = q + sigma_q * rng.standard_normal(nv)
            if sigma_e > 0:
                tau = tau + sigma_e * rng.standard_normal(nv)
            msg.position = q.tolist()
            msg.velocity = sim.data.qvel.tolist()
            msg.effort = tau.tolist()
            try:
                self._pub.publish(msg)
            except Exception:  # the context is shutting down
                return

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        if self.record_file:
            n = self._n_rec
            np.savez(self.record_file, joints=np.array(self.robot.joints), fault=self.fault, fault_ns=self.fault_ns,
                     hold_ns=np.array(self.hold_ns, dtype=np.int64), **{k: v[:n] for k, v in self._rec.items()})


def main(argv: list[str] | None = None) -> int:
    return run_node(SimNode, argv)


if __name__ == "__main__":
    sys.exit(main())
