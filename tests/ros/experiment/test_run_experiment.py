"""``~/run_experiment`` across processes: the frictionid node (system tx40) and the simulated TX40 as a
position-controlled robot (``frictionid_sim``, ``command_interface: position``: its servo follows
JointTrajectory and streamed positions), real rclpy, a short excitation (4 s, 3 harmonics) at 100 points
per second. A goal runs to its judgement and applies the result; a cancel and an effort fault abort it:
the arm is told to hold and comes to rest, nothing is applied, the node still answers ``~/identify``."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from action_msgs.msg import GoalStatus
    from frictionid_interfaces.action import RunExperiment
    from rcl_interfaces.srv import SetParameters
    from rclpy.parameter import Parameter

    from frictionid_ros.runtime.action_client import ActionClient

import frictionid_core as fid
from frictionid_core.loop import default_trajectory, hidden_friction, load_robot
from support.ros_harness import _LEASES, DOMAIN, node_env, start_node

pytestmark = [pytest.mark.ros, pytest.mark.slow, pytest.mark.filterwarnings("ignore::DeprecationWarning")]
ACTION = "/frictionid/run_experiment"
SHORT = dict(duration_s=4.0, harmonics=3, period_s=4.0, evals=60)  # a design of ~1 s
# On the shared 2-core machine (load 7-8 with other agents' loops at SCHED_FIFO) this process and the node
# were seen to pause for 0.2-0.35 s: a test that is not about silence allows 1 s of it (the default 0.25 s
# is measured by frictionid experiment's --fault silence, docs/experiment.md)
QUIET = dict(silence_s=1.0)
SLOW = dict(SHORT, max_acceleration=1.0)
STILL = 0.01  # [rad/s]: at rest


class Arm:
    def __init__(self, work: Path, node, sim: subprocess.Popen, results: Path):
        self.work, self.node, self.sim, self.results = work, node, sim, results
        self.excitation = ""  # the designed excitation of the first goal (relative to the results folder)

    def active(self) -> str | None:
        """The node's active parameters file as text (None before anything was applied)."""
        path = self.results / "parameters.json"
        return path.read_text() if path.is_file() else None

    def replay(self) -> dict:
        """Goal fields that replay the first goal's excitation, or (that test not run, e.g. ``-k``) design
        a short one."""
        return dict(excitation_file=self.excitation) if self.excitation else dict(SHORT)


@pytest.fixture(scope="module")
def arm(tmp_path_factory, ros):
    work = tmp_path_factory.mktemp("experiment")
    results = work / "results"
    results.mkdir()
    robot = load_robot("tx40")
    params = work / "params.yaml"
    # known_rigid_body: the links as modelled, the rotor inertias, friction and offsets identified: a 2.8 s
    # fit determines those (the 40 base parameters need the 20 s excitation of frictionid experiment)
    params.write_text(f"""/**/frictionid:
  ros__parameters:
    joints: {json.dumps(list(robot.joints))}
    system: "tx40"
    known_rigid_body: true
    diagnostics_period_s: 0.5
    buffer_seconds: 30.0
    unique_name: false
    results_file: "{results / 'parameters.json'}"
""")
    q0 = [float(x) for x in default_trajectory(robot).q0]
    with open(work / "sim.out", "w") as out, open(work / "sim.err", "w") as err:
        sim = subprocess.Popen([sys.executable, "-m", "frictionid_ros.loop.sim_node", "--ros-args", "-p", "robot:=tx40",
                                "-p", "command_interface:=position", "-p", f"q0:={q0}", "-p", "effort_noise:=0.05",
                                "-p", "position_noise:=1e-6", "-p", "fault_joint:=1",
                                "-p", f"record_file:={work / 'sim_record.npz'}"], env=node_env(DOMAIN),
                               stdout=out, stderr=err, cwd=work, pass_fds=(_LEASES[DOMAIN].fd,))
    node = start_node(work, ros, params, "experiment")
    try:
        ros.wait_received(2000, timeout=120.0)  # the arm's joint states flow
        yield Arm(work, node, sim, results)
    finally:
        node.stop()
        sim.terminate()
        sim.wait(30)


def run_goal(ros, feedback: list, on_feedback=None, cancel_in: str = "", **fields):
    """Send a RunExperiment goal; returns (status, result). ``on_feedback(fb)`` for each feedback;
    ``cancel_in``: cancel the goal once its feedback shows this phase."""
    client = getattr(ros, "_experiment_client", None)
    if client is None:
        client = ros._experiment_client = ActionClient(ros.node, RunExperiment, ACTION)
    assert client.wait_for_server(timeout_sec=60.0)
    holder: dict = {}
    cancelled = threading.Event()

    def fb_cb(msg):
        fb = msg.feedback
        feedback.append(fb)
        if on_feedback is not None:
            on_feedback(fb)
        if cancel_in and fb.phase == cancel_in and not cancelled.is_set() and "handle" in holder:
            cancelled.set()
            holder["handle"].cancel_goal_async()

    # the answer to a goal waits for the node's executor: on a machine loaded by two other processes it took
    # over 30 s once (the run after the previous goal's hold); a dead node still fails within two minutes
    handle = ros.wait(client.send_goal_async(RunExperiment.Goal(**fields), feedback_callback=fb_cb), 120.0, "goal")
    holder["handle"] = handle
    assert handle.accepted
    res = ros.wait(handle.get_result_async(), 300.0, "result")
    return res.status, res.result


def set_fault(ros, value: str) -> None:
    req = SetParameters.Request(parameters=[Parameter("fault", value=value).to_parameter_msg()])
    res = ros.call(SetParameters, "/frictionid_sim/set_parameters", req, timeout=30.0)
    assert res.results[0].successful, res.results[0].reason


def test_an_experiment_is_designed_run_recorded_judged_and_applied(arm, ros):
    feedback: list = []
    status, result = run_goal(ros, feedback, max_floor_ratio=100.0, **SHORT, **QUIET)
    assert status == GoalStatus.STATUS_SUCCEEDED, result.message
    assert result.success and result.accepted and result.applied and not result.aborted, result.message
    phases = [fb.phase for fb in feedback]
    for phase in ("plan", "approach", "excitation", "identification"):
        assert phase in phases, phases
    report = json.loads(result.json)
    assert report["excitation"]["duration"] == 4.0 and report["screen"]["excitation"]["ok"]
    arm.excitation = str(Path(report["excitation_file"]).relative_to(arm.results))
    # the bag: every joint state of the excitation and its lead and tail (1 kHz, ~5 s; a loaded machine may
    # lose a few), read back as frictionid identify reads it
    series = fid.load(result.bag)
    assert series.joints == [f"joint_{k}" for k in range(1, 7)] and 4.5 < series.t[-1] < 6.0
    assert len(series.t) >= 0.9 * 1000 * series.t[-1]
    # the result's request holds the fit's window: the bag identified again gives the same parameters
    again = fid.identify(series, fid.read_request(result.result_file))
    saved = json.loads(Path(result.result_file).read_text())["params"]
    assert again.params == pytest.approx(saved, rel=1e-9, abs=1e-12)
    v = report["validation"]
    assert v["relerr_pct"] == pytest.approx(result.validation_relerr_pct) and v["noise_floor_pct"] > 0
    # 2.8 s of excitation, 0.05 N·m of effort noise, the Coulomb law on a Stribeck arm (vs ≤ 0.05 rad/s):
    # Fv and Fc within 10 % of the hidden truth (the 20 s experiment: within 1 %, docs/experiment.md)
    truth = hidden_friction("tx40", series.joints)
    for k, j in enumerate(series.joints):
        assert saved[f"{j}/Fv"] == pytest.approx(truth[k, 0], rel=0.10), j
        assert saved[f"{j}/Fc"] == pytest.approx(truth[k, 1], rel=0.10), j
    # applied: the active parameters, saved and published (transient local)
    active = json.loads((arm.results / "parameters.json").read_text())
    assert active["per_joint"]["joint_2"]["params"]["Fc"] == pytest.approx(saved["joint_2/Fc"])
    assert [p.joint_name for p in ros.latched_parameters().joints] == series.joints


def held_and_nothing_applied(arm, ros, result, reason: str) -> dict:
    report = json.loads(result.json)
    assert result.aborted and result.abort_reason == reason and not result.applied, result.message
    assert not result.result_file  # nothing identified after an abort
    # the node saw the arm at rest within 0.5 s of telling it to hold (a 25 Hz servo brakes within ~0.1 s)
    assert report["stopped_after_s"] is not None and report["stopped_after_s"] <= 0.5, report
    # still serving ~/identify: answered at once, not busy (whether the last seconds, mostly at rest, move
    # every joint enough to identify is another matter)
    answer = ros.identify(window_seconds=8.0, dry_run=True, timeout=60.0)
    assert answer.message and not answer.message.startswith("busy"), answer.message
    return report


def test_a_cancel_holds_the_arm_and_applies_nothing(arm, ros):
    before = arm.active()
    feedback: list = []
    status, result = run_goal(ros, feedback, cancel_in="excitation", max_floor_ratio=100.0, **arm.replay(), **QUIET)
    assert status == GoalStatus.STATUS_CANCELED, result.message
    report = held_and_nothing_applied(arm, ros, result, "cancel")
    assert report["abort_text"] == "cancelled by the client"
    assert arm.active() == before
    assert Path(result.bag).is_dir()  # what was recorded until the cancel stays


def test_an_effort_beyond_the_limit_aborts_and_applies_nothing(arm, ros):
    before = arm.active()
    sent = threading.Event()

    def spike(fb):
        if fb.phase == "excitation" and fb.progress > 0.3 and not sent.is_set():
            sent.set()
            threading.Thread(target=set_fault, args=(ros, "effort"), daemon=True).start()

    try:
        status, result = run_goal(ros, [], on_feedback=spike, max_floor_ratio=100.0, **arm.replay(), **QUIET)
    finally:
        set_fault(ros, "")
    assert status == GoalStatus.STATUS_ABORTED
    report = held_and_nothing_applied(arm, ros, result, "effort")
    text = report["abort_text"]
    assert text.startswith("effort of joint_2 ") and "beyond 1 × its limit 131.8" in text, text
    assert arm.active() == before


@pytest.mark.long
def test_streamed_positions_and_a_dry_run(arm, ros):
    """The position interface: the node streams the motion at 250 Hz (each command 40 ms ahead, the arm
    playing them back from a 40 ms buffer); a dry run judges, applies nothing. The arm's clock is its
    simulation's, which a loaded machine stalls now and then while the node's commands keep wall-clock
    time (and the node's own pauses, 0.2-0.35 s at worst, run the 40 ms buffer dry): the arm then falls
    behind them by as much. So the excitation is a slow one here (every acceleration within 1 rad/s²: a 4 s
    period then leaves speeds ≲ 0.65 rad/s, 0.23 rad in 0.35 s) and the tracking threshold 0.25 rad (the
    trajectory interface, timed by the arm's own clock, keeps the default 0.05)."""
    before = arm.active()
    status, result = run_goal(ros, [], command_interface="position", max_floor_ratio=100.0, dry_run=True,
                              max_tracking_error=0.25, **SLOW, **QUIET)
    report = json.loads(result.json or "{}")
    # on a failure: what the monitor saw and how regularly the node checked (a loaded machine's pauses)
    assert status == GoalStatus.STATUS_SUCCEEDED, (result.message, {k: report.get(k) for k in (
        "monitor", "watch_max_interval_s", "wall_s", "abort_stamp_ns", "excitation_start_ns")})
    assert result.accepted and not result.applied and result.reason == "dry run: nothing applied"
    assert report["command"] == {"interface": "position", "topic": "/forward_position_controller/commands",
                                 "rate_hz": 250.0}
    assert max(report["monitor"]["max_tracking_error"].values()) < 0.25
    assert arm.active() == before


def test_a_bad_goal_is_refused_before_anything_moves(arm, ros):
    status, result = run_goal(ros, [], command_interface="velocity")
    assert status == GoalStatus.STATUS_ABORTED and not result.aborted
    assert result.message == "goal field 'command_interface' = 'velocity': choose one of trajectory, position"
    status, result = run_goal(ros, [], excitation_file="../outside.npz")
    assert status == GoalStatus.STATUS_ABORTED and not result.aborted and "results folder" in result.message
