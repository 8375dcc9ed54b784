"""What a client on the ROS domain cannot do to the node, across processes with real rclpy.

The node runs as a subprocess fed the first 8 s of the EMPS estimation bag. Each abuse attempt
is refused with a message naming the rule or limit and changes no file; a running
identification can be cancelled (action cancel, ``~/reset``) or is stopped at ``max_wall_s``,
leaving the active parameters untouched; the action reports progress; and the node keeps
publishing its feed-forward throughout (``Ros.assert_alive``: a fresh joint state gets its
feed-forward). Requests name their data window by stamps, so the probe joint states of
``assert_alive`` never enter an identification.
"""

from __future__ import annotations

import json
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from support.ros_harness import DOMAIN, NS, ROOT, NodeProcess, Ros, private_domain, start_node
from support.waiting import wait_until

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from action_msgs.msg import GoalStatus
    from builtin_interfaces.msg import Time
    from frictionid_interfaces.srv import ParametersFile
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState, GetState
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import DescribeParameters, SetParameters
    from std_srvs.srv import Trigger

from frictionid_ros import replay
from frictionid_ros.store import JointParams, Results, read_results, write_results

pytestmark = [pytest.mark.ros, pytest.mark.filterwarnings("ignore::DeprecationWarning")]

BAG = ROOT / "bags" / "emps_estimation"
SECONDS = 8.0  # replayed part of the bag [s]
# The node's limits: a budget high enough for a job that runs for minutes on any machine (HUGE).
LIMITS = dict(max_budget=100_000, max_population=200, max_window_seconds=60.0)
HUGE = dict(friction_model="tustin", solver="de", population=200, budget=100_000)
OWN_DOMAIN = private_domain()  # of the tests that start a node of their own


def _time(ns: int) -> Time:
    return Time(sec=ns // NS, nanosec=ns % NS)


def _params_file(workdir: Path, name: str, **extra) -> Path:
    lines = "".join(f"    {k}: {json.dumps(v)}\n" for k, v in extra.items())
    p = workdir / f"{name}.yaml"
    p.write_text(f"""/**/frictionid:
  ros__parameters:
    joints: ["emps"]
    system: "emps"
    qos: "reliable"
    qos_depth: 2000
    diagnostics_period_s: 0.2
    results_file: "{workdir / name / 'parameters.json'}"
{lines}""")
    return p


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("frictionid_harden")


def _start(workdir: Path, ros: Ros, name: str, *args: str, domain: int = DOMAIN, **params) -> NodeProcess:
    return start_node(workdir, ros, _params_file(workdir, name, **LIMITS, **params), name, *args, domain=domain)


def _feed(ros: Ros, seconds: float = SECONDS, rate: float = 2.0) -> dict:
    """Replay ``seconds`` of the bag into the node at ``rate`` x real time; returns the request
    fields of exactly that window."""
    stats = ros.feed(replay.load_stream(BAG, duration=seconds), rate)
    start = stats["first_stamp_ns"]
    return dict(window_start=_time(start), window_end=_time(start + int(seconds * NS)))


@pytest.fixture
def own_ros():
    """A client on a domain of its own, for a test with a node of its own."""
    r = Ros(OWN_DOMAIN)
    yield r
    r.close()


@pytest.fixture(scope="module")
def node(workdir, ros):
    proc = _start(workdir, ros, "main")
    yield proc
    proc.stop()


@pytest.fixture(scope="module")
def window(ros, node) -> dict:
    """The data window; identified once, so that parameters are active and fed forward."""
    w = _feed(ros)
    res = ros.identify(**w)
    assert res.success, res.message
    return w


def _active(ros: Ros) -> list[float]:
    return list(ros.latched_parameters().joints[0].param_values)


def _file_request(ros: Ros, service: str, path: str):
    return ros.call(ParametersFile, f"/frictionid/{service}", ParametersFile.Request(path=str(path)))


def _wait_busy(ros: Ros, proc: NodeProcess, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while ros.diag_value("busy", status="frictionid: identification", newer_than=time.monotonic()) != "True":
        assert proc.alive() and time.monotonic() < deadline, "the identification did not start"


# --------------------------------------------------------------------------- files


def test_save_and_load_stay_inside_the_results_folder(window, ros, node, workdir):
    folder = workdir / "main"  # the folder of results_file
    outside = workdir / "outside"
    outside.mkdir()
    notes = outside / "notes.txt"
    notes.write_text("not yours\n")
    (folder / "link").symlink_to(outside, target_is_directory=True)
    (folder / "evil.json").symlink_to(notes)
    (folder / "notes.txt").write_text("an operator's file\n")
    before = {p: p.read_bytes() for p in (notes, folder / "notes.txt")}
    cases = [
        ("save", str(notes), "outside the results folder"),
        ("save", "../outside/notes.txt", "'..'"),
        ("save", str(folder / ".." / "outside" / "notes.txt"), "'..'"),
        ("save", "link/new.json", "symbolic link"),
        ("save", "evil.json", "symbolic link"),
        ("save", "sub/dir/new.json", "no such folder"),
        ("load", str(notes), "outside the results folder"),
        ("load", "/no/such/file.json", "outside the results folder"),  # the same answer: nothing is looked at
        ("load", "link/notes.txt", "symbolic link"),
    ]
    for service, path, needle in cases:
        res = _file_request(ros, service, path)
        assert not res.success and "refused" in res.message and needle in res.message, (service, path, res.message)
        assert f"inside the results folder {folder}" in res.message and res.path == ""
    res = _file_request(ros, "save", "notes.txt")  # inside, but not the node's
    assert not res.success and "refused" in res.message and "not a parameters file written by this node" in res.message
    assert {p: p.read_bytes() for p in before} == before
    assert sorted(p.name for p in outside.iterdir()) == ["notes.txt"] and not (folder / "sub").exists()
    # inside the folder: a new file, then over the node's own file, then back
    for _ in range(2):
        res = _file_request(ros, "save", "mine.json")
        assert res.success and res.path == str(folder / "mine.json"), res.message
    assert read_results(folder / "mine.json").per_joint.keys() == {"emps"}
    res = _file_request(ros, "load", "mine.json")
    assert res.success, res.message
    ros.assert_alive(node)


def test_path_and_limit_parameters_are_fixed_at_start(window, ros, node, workdir):
    """No runtime parameter change can point the node at another file or lift a limit."""
    changes = {"system": "urdf:/tmp/robot.urdf", "results_file": str(workdir / "elsewhere.json"),
               "results_dir": "/", "max_budget": 2_000_000_000, "max_wall_s": 1e9}
    for name, value in changes.items():
        if isinstance(value, str):
            v = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
        elif isinstance(value, int):
            v = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=value)
        else:
            v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
        res = ros.call(SetParameters, "/frictionid/set_parameters",
                       SetParameters.Request(parameters=[Parameter(name=name, value=v)]))
        assert not res.results[0].successful and "read-only" in res.results[0].reason, (name, res.results[0].reason)
    # a default the client may change is held to the limits too
    v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=1000.0)
    res = ros.call(SetParameters, "/frictionid/set_parameters",
                   SetParameters.Request(parameters=[Parameter(name="window_seconds", value=v)]))
    assert not res.results[0].successful and "max_window_seconds" in res.results[0].reason, res.results[0].reason
    # below its declared range: refused by rclpy itself (the descriptor's range, as ros2 param describe shows it)
    v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=-1.0)
    res = ros.call(SetParameters, "/frictionid/set_parameters",
                   SetParameters.Request(parameters=[Parameter(name="window_seconds", value=v)]))
    assert not res.results[0].successful and "out of range" in res.results[0].reason, res.results[0].reason
    nice = ros.call(DescribeParameters, "/frictionid/describe_parameters",
                    DescribeParameters.Request(names=["worker_nice"])).descriptors[0]
    assert nice.read_only and [(r.from_value, r.to_value) for r in nice.integer_range] == [(0, 19)]


# --------------------------------------------------------------------------- limits


def test_requests_over_a_limit_are_refused(window, ros, node):
    active = _active(ros)
    cases = [(dict(budget=2_000_000_000), "'budget' = 2000000000 is over the node's limit max_budget = 100000"),
             (dict(population=100_000), "'population' = 100000 is over the node's limit max_population = 200"),
             (dict(window_seconds=3600.0),
              "window_seconds = 3600 s is over the node's limit max_window_seconds = 60 s"),
             (dict(window_start=_time(1 * NS), window_end=_time(7200 * NS)), "max_window_seconds = 60 s")]
    for fields, needle in cases:
        res = ros.identify(solver="de", **fields)
        assert not res.success and needle in res.message, (fields, res.message)
        handle = ros.send_goal(solver="de", **fields)
        got = ros.wait(handle.get_result_async(), 30.0, "action result")
        assert got.status == GoalStatus.STATUS_ABORTED and needle in got.result.message, got.result.message
    assert not ros.identify(**window, **{**HUGE, "budget": 100_001}).success  # HUGE is at the limit, one more is not
    assert _active(ros) == active
    res = ros.identify(**window)  # not stuck busy
    assert res.success, res.message
    ros.assert_alive(node)


# --------------------------------------------------------------------------- action, cancel


def test_action_progress_then_cancel(window, ros, node):
    active = _active(ros)
    feedback = []
    handle = ros.send_goal(feedback, **window, **HUGE)
    deadline = time.monotonic() + 60
    while not feedback or feedback[-1].generation < 2:  # progress of the optimiser itself
        assert time.monotonic() < deadline, f"no progress in the feedback ({feedback[-1:]})"
        time.sleep(0.05)
    ros.assert_alive(node)  # feed-forward during the identification
    busy = ros.send_goal(**window)  # a second goal meanwhile: answered busy
    got = ros.wait(busy.get_result_async(), 30.0)
    assert got.status == GoalStatus.STATUS_ABORTED and got.result.message.startswith("busy"), got.result.message
    ros.wait(handle.cancel_goal_async(), 10.0, "cancel")
    got = ros.wait(handle.get_result_async(), 30.0, "cancelled result")
    assert got.status == GoalStatus.STATUS_CANCELED, (got.status, got.result.message)
    assert not got.result.success and got.result.message.startswith("cancelled by the client after")
    assert "active parameters unchanged" in got.result.message
    with ros.lock:
        fb = list(feedback)
    evaluations = [f.evaluations for f in fb]
    best = [f.best_cost for f in fb if np.isfinite(f.best_cost)]
    assert evaluations == sorted(evaluations) and evaluations[-1] >= 400
    assert best and best == sorted(best, reverse=True) and best[-1] > 0
    assert [f.elapsed_s for f in fb] == sorted(f.elapsed_s for f in fb)
    assert all(f.generation * 200 == f.evaluations for f in fb)  # de: one population per generation
    assert _active(ros) == active
    res = ros.identify(**window)  # the next identification runs at once
    assert res.success, res.message
    ros.assert_alive(node)


def test_reset_cancels_a_running_identification(window, ros, node):
    active = _active(ros)
    box = {}
    t = threading.Thread(target=lambda: box.setdefault("res", ros.identify(timeout=120, **window, **HUGE)))
    t.start()
    _wait_busy(ros, node)
    ros.assert_alive(node)
    res = ros.call(Trigger, "/frictionid/reset", Trigger.Request())
    assert res.success and res.message.endswith("; running identification cancelled"), res.message
    t.join(60)
    assert not box["res"].success and box["res"].message.startswith("cancelled by ~/reset after"), box["res"].message
    assert _active(ros) == active
    w = _feed(ros, seconds=4.0, rate=1.0)  # the reset emptied the buffer
    res = ros.identify(**w)
    assert res.success, res.message
    ros.assert_alive(node)


# --------------------------------------------------------------------------- wall time, lifecycle


@pytest.mark.slow
@pytest.mark.long
def test_wall_time_limit_stops_a_job(own_ros, workdir):
    ros = own_ros
    # 10 s: an ordinary fit of the window (the first one starting the worker) stays well inside it
    # on a loaded machine; the huge job cannot end in it
    proc = _start(workdir, ros, "walltime", domain=OWN_DOMAIN, max_wall_s=10.0)
    try:
        w = _feed(ros)
        res = ros.identify(**w)
        assert res.success, res.message
        active = _active(ros)
        feedback = []
        handle = ros.send_goal(feedback, **w, **HUGE)
        got = ros.wait(handle.get_result_async(), 60.0, "stopped result")
        assert got.status == GoalStatus.STATUS_ABORTED, got.result.message
        assert got.result.message.startswith("stopped: over the wall-time limit max_wall_s = 10 s after"), \
            got.result.message
        assert feedback and _active(ros) == active
        res = ros.identify(**w)
        assert res.success, res.message
        ros.assert_alive(proc)
        assert proc.stop() == 0 and "Traceback" not in proc.stderr(), proc.stderr()
    finally:
        if proc.alive():
            proc.stop()


@pytest.mark.slow
def test_lifecycle_node(own_ros, workdir):
    """--lifecycle: nothing before configure; feed-forward only while active; cleanup removes it all."""
    ros = own_ros
    name = "managed"
    (workdir / name).mkdir()
    params = JointParams("emps", "emps", "coulomb", False, "ls", {"M": 95.0, "Fv": 200.0, "Fc": 20.0, "offset": -3.0})
    write_results(workdir / name / "parameters.json", Results({"emps": params}))  # restored at configure
    proc = _start(workdir, ros, name, "--lifecycle", domain=OWN_DOMAIN)
    try:
        ros.wait_service(proc, "/frictionid/get_state", GetState)

        def state() -> str:
            return ros.call(GetState, "/frictionid/get_state", GetState.Request()).current_state.label

        def change(transition: int) -> None:
            assert ros.call(ChangeState, "/frictionid/change_state",
                            ChangeState.Request(transition=Transition(id=transition))).success

        def assert_no_feedforward(first_stamp: int) -> None:
            """Joint states are buffered, no feed-forward is published."""
            published = int(ros.diag_value("ff_published", status="frictionid: identification",
                                           newer_than=time.monotonic()))
            received = ros.received()
            stamps = first_stamp + np.arange(50) * 1_000_000
            ros.publish_states(stamps, np.zeros(50), np.full(50, 0.05), np.zeros(50), rate_hz=500, wait=True)
            assert ros.received() >= received + 50
            assert int(ros.diag_value("ff_published", status="frictionid: identification",
                                      newer_than=time.monotonic())) == published
            assert ros.diag_value("feedforward_on", status="frictionid: identification") == "False"

        assert state() == "unconfigured"
        assert not ros.node.create_client(ParametersFile, "/frictionid/save").wait_for_service(timeout_sec=1.0)
        change(Transition.TRANSITION_CONFIGURE)
        assert state() == "inactive"
        ros.wait_service(proc)
        assert_no_feedforward(9_000 * NS)
        change(Transition.TRANSITION_ACTIVATE)
        assert state() == "active"
        ros.assert_alive(proc)  # the restored parameters fed forward
        change(Transition.TRANSITION_DEACTIVATE)
        assert_no_feedforward(9_100 * NS)
        change(Transition.TRANSITION_CLEANUP)
        assert state() == "unconfigured"
        cli = ros.node.create_client(ParametersFile, "/frictionid/save")
        wait_until(lambda: not cli.service_is_ready(), "end of ~/save after cleanup", proc=proc)
        change(Transition.TRANSITION_CONFIGURE)  # configure again, then shut down
        ros.wait_service(proc)
        change(Transition.TRANSITION_INACTIVE_SHUTDOWN)
        assert state() == "finalized"
        assert proc.stop() == 0 and "Traceback" not in proc.stderr(), proc.stderr()
    finally:
        if proc.alive():
            proc.stop()
