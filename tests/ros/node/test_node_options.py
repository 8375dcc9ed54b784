"""The frictionid ROS 2 node across processes, options and a whole robot: a Float64MultiArray effort
topic with a reference velocity and a thread worker; the full TX40 replayed from its bag.

A module of their own: each starts its own node, and none shares the CPU with the module-scoped
node of tests/ros/node/test_node.py (a replay must arrive whole); the publishers are processes of their own, as a user
runs them.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest

from support import publish_unstamped_effort
from support.ros_harness import DOMAIN, NS, RELIABLE, ROOT, NodeProcess, node_env
from support.waiting import wait_until

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray
    from frictionid_interfaces.srv import Identify
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

from frictionid_core.friction import get_model
from frictionid_core.identification import IdentifyRequest, identify
from frictionid_core.io import load
from frictionid_ros import replay

pytestmark = [pytest.mark.ros, pytest.mark.filterwarnings("ignore::DeprecationWarning")]

EPS = 0.01  # smoothing_eps of the node under test [rad/s]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("frictionid_ros_options")


@pytest.mark.slow
def test_effort_topic_reference_velocity_and_thread_worker(ros, workdir):
    """Other options: a Float64MultiArray effort topic, joint_states in another joint order, the
    feed-forward from a reference topic on a 50 Hz timer, friction-only, identification in a thread,
    the SingleThreadedExecutor for the inputs, a namespace."""
    ns = "/opt"
    params = workdir / "opt.yaml"
    params.write_text(f"""/**/frictionid:
  ros__parameters:
    joints: ["a", "b"]
    system: "friction-only"
    effort_topic: "effort"
    effort_topic_type: "float64_multi_array"
    velocity_source: "reference"
    reference_topic: "reference"
    feedforward_rate_hz: 50.0
    smoothing_eps: 0.0
    identification_worker: "thread"
    input_executor: "single_threaded"
    qos: "reliable"
    qos_depth: 2000
    max_missing_pct: 50.0
    diagnostics_period_s: 0.2
    filter_cutoff_hz: 100.0         # an effort paired by receipt time jitters by a few ms: an analysis
    decimation: 10                  # rate of 50 Hz (as the former default) averages that out
    results_file: "{workdir / 'opt' / 'parameters.json'}"
""")
    proc = NodeProcess(workdir, ["--ros-args", "--params-file", str(params), "-r", f"__ns:={ns}"], "opt")
    n = ros.node
    ref = n.create_publisher(JointState, f"{ns}/reference", RELIABLE)
    got = []
    n.create_subscription(Float64MultiArray, f"{ns}/frictionid/friction_torque", got.append, RELIABLE)
    try:
        cli = n.create_client(Identify, f"{ns}/frictionid/identify")
        wait_until(lambda: cli.wait_for_service(timeout_sec=0.2), "the node's ~/identify", 120, proc=proc)
        fv, fc = publish_unstamped_effort.FV, publish_unstamped_effort.FC  # joints a, b
        pub = subprocess.run([sys.executable, str(Path(publish_unstamped_effort.__file__)), ns], env=node_env(DOMAIN),
                             capture_output=True, text=True, timeout=300)
        assert pub.returncode == 0, pub.stderr
        # everything acknowledged by the node's readers: wait until its input thread has taken it in
        for key in ("received", "effort_received"):
            ros.wait_received(publish_unstamped_effort.N, status="opt/frictionid: joint buffer", key=key)
        done = threading.Event()
        fut = cli.call_async(Identify.Request())
        fut.add_done_callback(lambda _: done.set())
        assert done.wait(120)
        res = fut.result()
        assert res.success, res.message
        joints = {j.joint_name: dict(zip(j.param_names, j.param_values)) for j in res.result.joints}
        assert sorted(joints) == ["a", "b"] and set(joints["a"]) == {"Fv", "Fc", "offset"}
        # The unstamped effort is paired with the joint states by receipt time: a publisher stalled
        # between its two publishes shifts the effort by that stall, which moves the sign step at
        # each reversal and so Fc (measured: up to −55 % when this process also published while
        # spinning the client, 5 % alone); Fv is insensitive to it. The publisher is a process of its
        # own (tests/support/publish_unstamped_effort.py); the stamped paths are checked to 5 % elsewhere.
        for i, name in enumerate(["a", "b"]):
            assert joints[name]["Fv"] == pytest.approx(fv[i], rel=0.05), (name, joints)
            assert 0.0 < joints[name]["Fc"] < 1.5 * fc[i], (name, joints)
        # feed-forward: desired velocities of the reference topic, published by the 50 Hz timer
        v_ref = np.array([0.1, -0.2])
        want = [get_model("coulomb").torque([joints[j]["Fv"], joints[j]["Fc"]], [v_ref[i]])[0]
                for i, j in enumerate(["a", "b"])]

        def fed_forward() -> bool:  # the reference again each time: the node may not have matched it yet
            ref.publish(JointState(name=["a", "b"], position=[0.0, 0.0], velocity=v_ref.tolist()))
            return bool(got) and np.allclose(got[-1].data, want, rtol=1e-12, atol=0)

        try:
            wait_until(fed_forward, "feed-forward of the reference velocity", period=0.1, proc=proc)
        except AssertionError as exc:
            raise AssertionError(f"{exc}: last {got[-1].data if got else None}, expected {want}") from None
        assert proc.stop(signal.SIGTERM) == 0 and "Traceback" not in proc.stderr(), proc.stderr()
    finally:
        if proc.alive():
            proc.stop(signal.SIGKILL)


@pytest.mark.slow
@pytest.mark.long
def test_full_tx40_robot_from_a_replayed_bag(ros, workdir):
    """The six-joint TX40 (Pinocchio base parameters + per-joint Coulomb friction): the node fed
    the bundled excitation bag agrees with the offline identification of the same samples, the
    base parameters come as shared parameters, the feed-forward of every joint is the core
    model with that joint's friction, and with ``consistent`` set the answer and /diagnostics
    carry the consistency verdict."""
    bag = ROOT / "bags" / "tx40_excitation"
    ns = "/robot"
    params = workdir / "robot.yaml"
    params.write_text(f"""/**/frictionid:
  ros__parameters:
    joints: ["joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6"]
    system: "tx40"
    qos: "reliable"
    qos_depth: 2000
    smoothing_eps: {EPS}
    results_file: "{workdir / 'robot' / 'parameters.json'}"
""")
    proc = NodeProcess(workdir, ["--ros-args", "--params-file", str(params), "-r", f"__ns:={ns}"], "robot")
    try:
        cli = ros.node.create_client(Identify, f"{ns}/frictionid/identify")
        wait_until(lambda: cli.wait_for_service(timeout_sec=0.2), "the node's ~/identify", 120, proc=proc)
        # replayed as a user does, from a process of its own, in real time (1000 msg/s)
        pub = subprocess.run([sys.executable, "-m", "frictionid_ros.replay", str(bag), "--rate", "1",
                              "--publish-topic", f"{ns}/joint_states", "--depth", "2000", "--wait", "60"],
                             env=node_env(DOMAIN), capture_output=True, text=True, timeout=300)
        assert pub.returncode == 0 and "warning" not in pub.stderr, pub.stderr
        stats = {"sent": len(replay.load_stream(bag))}
        assert f"published {stats['sent']} messages" in pub.stdout, pub.stdout
        # taken in by the node's input thread: every message, or at least 99 % once no more come
        # (two /diagnostics in a row agree, the replay having ended)
        counts = [-1]

        def taken_in() -> bool:
            counts.append(ros.received(status="robot/frictionid: joint buffer"))
            return counts[-1] >= stats["sent"] or counts[-1] == counts[-2] >= 0.99 * stats["sent"]

        try:
            wait_until(taken_in, "joint states taken in by the node", period=0.0, proc=proc)
        except AssertionError as exc:
            raise AssertionError(f"{exc}: counts {counts[-3:]} of {stats['sent']} sent") from None
        res = ros.call(Identify, f"{ns}/frictionid/identify", Identify.Request(friction_model="coulomb"), 120)
        assert res.success, res.message
        r = res.result
        assert r.samples >= 0.99 * stats["sent"], (r.samples, stats["sent"])
        ref = identify(load(bag).slice(0, r.samples), IdentifyRequest(system="tx40", friction="coulomb")).to_dict()
        shared = dict(zip(r.shared_param_names, r.shared_param_values))
        assert list(shared) == [k for k in ref["params"] if "/" not in k] and len(shared) == 40
        for name, value in ref["params"].items():
            if "/" not in name and abs(value) > 0.05:  # the well-determined base parameters
                assert shared[name] == pytest.approx(value, rel=0.01), name
        friction = {j.joint_name: dict(zip(j.param_names, j.param_values)) for j in r.joints}
        assert list(friction) == [f"joint_{k}" for k in range(1, 7)]
        for joint, p in friction.items():
            assert set(p) == {"Fv", "Fc", "offset"} and r.joints[0].system_model == "tx40"
            for name in ("Fv", "Fc"):
                assert p[name] == pytest.approx(ref["params"][f"{joint}/{name}"], rel=0.01), (joint, name)
        # feed-forward: joint k's friction at joint k's velocity, ordered by `joints`
        got = []
        ros.node.create_subscription(JointState, f"{ns}/frictionid/friction_torque_state", got.append, RELIABLE)
        js = ros.node.create_publisher(JointState, f"{ns}/joint_states", RELIABLE)
        v = np.array([0.3, -0.2, 0.1, -0.05, 0.004, 0.0])
        stamp = 7_000 * NS
        msg = JointState(name=list(reversed(friction)), position=[0.0] * 6, velocity=v[::-1].tolist(),
                         effort=[0.0] * 6)  # another joint order than the node's
        msg.header.stamp = Time(sec=stamp // NS)

        def fed_forward() -> bool:  # the state again each time: the node may not have matched it yet
            js.publish(msg)
            return any(m.header.stamp.sec == stamp // NS for m in list(got))

        wait_until(fed_forward, "feed-forward of the TX40 joint state", period=0.1, proc=proc)
        state = next(m for m in list(got) if m.header.stamp.sec == stamp // NS)
        coulomb = get_model("coulomb")
        want = [coulomb.torque([p["Fv"], p["Fc"]], [v[k]], eps=EPS)[0] for k, p in enumerate(friction.values())]
        assert list(state.name) == list(friction)
        assert np.allclose(state.effort, want, rtol=1e-12, atol=1e-12), (list(state.effort), want)
        # consistent parameters on request of the node's parameter (no interface change): in the
        # answer's text and in /diagnostics
        diags = []
        ros.node.create_subscription(DiagnosticArray, "/diagnostics", diags.append, 10)
        on = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=True)
        res = ros.call(SetParameters, f"{ns}/frictionid/set_parameters",
                       SetParameters.Request(parameters=[Parameter(name="consistent", value=on)]))
        assert res.results[0].successful, res.results[0].reason
        res = ros.call(Identify, f"{ns}/frictionid/identify", Identify.Request(friction_model="coulomb", dry_run=True),
                       120)
        assert res.success and "; consistency: FEASIBLE (SDP " in res.message, res.message

        def consistency() -> str:
            values = [{kv.key: kv.value for kv in st.values} for d in list(diags) for st in d.status
                      if st.name.endswith("identification")]
            return values[-1].get("consistency", "") if values else ""

        try:
            wait_until(lambda: consistency().startswith("FEASIBLE"), "FEASIBLE consistency in /diagnostics",
                       period=0.2, proc=proc)
        except AssertionError as exc:
            raise AssertionError(f"{exc}: last '{consistency()}'") from None
        assert proc.stop(signal.SIGTERM) == 0 and "Traceback" not in proc.stderr(), proc.stderr()
    finally:
        if proc.alive():
            proc.stop(signal.SIGKILL)
