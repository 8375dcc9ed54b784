"""Never an absurd torque, never a hang: the node under bad parameter sets and worker faults, across
processes with real rclpy.

The node runs as a subprocess. An absurd parameters file is refused by ``~/load`` naming the
parameter and the limit, and nothing changes; the feed-forward never leaves its clamp, whatever
set is active or parameter set; with the identification worker stopped (SIGSTOP) ``~/save`` and
``~/reset`` answer at once and ``~/identify`` is answered at its wall-time limit, the worker
killed and restarted; a second node of the same name does not start. The deadlines of the calls
below only tell an answer from a hang; the node keeps publishing its feed-forward throughout.
"""

from __future__ import annotations

import json
import os
import signal
import threading
import time
import warnings
from pathlib import Path

import pytest

from support.ros_harness import NS, ROOT, NodeProcess, Ros, private_domain, start_node
from support.waiting import wait_until

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from builtin_interfaces.msg import Time
    from frictionid_interfaces.srv import ParametersFile
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters
    from std_srvs.srv import Trigger

from frictionid_ros import replay

pytestmark = [pytest.mark.ros, pytest.mark.filterwarnings("ignore::DeprecationWarning")]

BAG = ROOT / "bags" / "emps_estimation"
CLAMP = 5.0  # the node's feedforward_max in these tests [N]
OWN_DOMAIN = private_domain()  # of the tests that start nodes of their own


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
    feedforward_max: {CLAMP}
    results_file: "{workdir / name / 'parameters.json'}"
{lines}""")
    return p


def _identification(params: dict) -> dict:
    """A hand-written EMPS identification result of ``params``."""
    return {"system": "emps", "friction": "coulomb", "asymmetric": False, "solver": "ls", "source": "by hand",
            "joints": ["emps"], "params": params}


def _time(ns: int) -> Time:
    return Time(sec=ns // NS, nanosec=ns % NS)


def _feed(ros: Ros, seconds: float = 8.0) -> dict:
    """Replay ``seconds`` of the EMPS bag into the node; the request fields of exactly that window."""
    stats = ros.feed(replay.load_stream(BAG, duration=seconds), 2.0)
    start = stats["first_stamp_ns"]
    return dict(window_start=_time(start), window_end=_time(start + int(seconds * NS)))


def _load(ros: Ros, path) -> ParametersFile.Response:
    return ros.call(ParametersFile, "/frictionid/load", ParametersFile.Request(path=str(path)))


def _set(ros: Ros, name: str, value: float):
    v = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
    return ros.call(SetParameters, "/frictionid/set_parameters",
                    SetParameters.Request(parameters=[Parameter(name=name, value=v)])).results[0]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("frictionid_safety")


@pytest.fixture
def own_ros():
    r = Ros(OWN_DOMAIN)
    yield r
    r.close()


def test_absurd_sets_are_refused_and_the_torque_stays_within_the_clamp(workdir, ros):
    node = start_node(workdir, ros, _params_file(workdir, "clamp"), "clamp")
    try:
        folder = workdir / "clamp"
        # accepted: a hand-written set without data limits is held to feedforward_max (Fc = 4 < 5)
        (folder / "strong.json").write_text(json.dumps(_identification({"M": 95.0, "Fv": 100.0, "Fc": 4.0,
                                                                        "offset": 0.0})))
        res = _load(ros, "strong.json")
        assert res.success, res.message
        active = list(ros.latched_parameters().joints[0].param_values)
        saved = (folder / "parameters.json").read_bytes()
        for name, params, needle in [
            ("huge.json", {"M": 95.0, "Fv": 200.0, "Fc": 1e6, "offset": 0.0}, "refused by the safety screen: "
             "parameter 'emps/Fc' = 1e+06 is over the effort limit 5 of 'emps' (the node's feedforward_max)"),
            ("negative.json", {"M": 95.0, "Fv": -1e6, "Fc": 2.0, "offset": 0.0}, "refused by the safety screen: "
             "parameter 'emps/Fv' = -1e+06 is negative (a physical magnitude, >= 0)"),
            ("absurd.json", {"M": 95.0, "Fv": 200.0, "Fc": 1e300, "offset": 0.0},  # the reader refuses it already
             "key 'params.Fc' must be a finite number within ±1e+15, got 1e+300"),
        ]:
            (folder / name).write_text(json.dumps(_identification(params)))
            res = _load(ros, name)
            assert not res.success and needle in res.message, res.message
        assert list(ros.latched_parameters().joints[0].param_values) == active
        assert (folder / "parameters.json").read_bytes() == saved  # nothing persisted
        # parameters shaping the torque: out of their declared range, refused by rclpy itself
        for name, value in (("smoothing_eps", float("inf")), ("smoothing_eps", float("nan")), ("smoothing_eps", 2.0),
                            ("feedforward_max", 1e9)):
            result = _set(ros, name, value)
            assert not result.successful and ("out of range" in result.reason or "read-only" in result.reason), \
                (name, value, result.reason)
        # Fv·v + Fc at ±10 m/s would be ±1004 N: the published torque is the clamp
        for k, v in enumerate((10.0, -10.0, 0.5, -0.5, 10.0)):
            torque = ros.probe(6_000 * NS + k * 1_000, v).effort[0]
            assert abs(torque) == pytest.approx(CLAMP) and (torque > 0) == (v > 0), (v, torque)
        ros.assert_alive(node)
        assert node.stop() == 0 and "Traceback" not in node.stderr(), node.stderr()
    finally:
        if node.alive():
            node.stop()


def _worker_pid(ros: Ros, old: int | None = None) -> int:
    """The worker process's pid from the node's diagnostics (another than ``old``)."""
    def pid():
        value = ros.diag_value("worker_pid", newer_than=time.monotonic())
        return int(value) if value and int(value) != old else None

    return wait_until(pid, "the worker's pid in the diagnostics", timeout=120)


def _identified(ros: Ros, window: dict) -> bool:
    res = ros.identify(**window)
    assert res.success or "over the wall-time limit" in res.message, res.message
    return res.success


@pytest.mark.slow
@pytest.mark.long
def test_a_stopped_worker_blocks_no_service(own_ros, workdir):
    """SIGSTOP the worker: ~/save answers at once while ~/identify waits; ~/identify is answered
    at max_wall_s with the worker killed and restarted; ~/reset answers at once and cancels the
    next stuck identification the same way; then identifications work again."""
    ros = own_ros
    wall = 3.0
    node = start_node(workdir, ros, _params_file(workdir, "stopped", max_wall_s=wall), "stopped", domain=OWN_DOMAIN)
    stopped = []
    try:
        window = _feed(ros)
        wait_until(lambda: _identified(ros, window), "an identification (the worker is warm)", timeout=120)
        for step, call, needle in [
            ("save", lambda: ros.call(ParametersFile, "/frictionid/save", ParametersFile.Request(path="mine.json"),
                                      timeout=10.0),
             f"stopped: over the wall-time limit max_wall_s = {wall:g} s after"),
            ("reset", lambda: ros.call(Trigger, "/frictionid/reset", Trigger.Request(), timeout=10.0),
             "cancelled by ~/reset after"),
        ]:
            if stopped:  # the new worker: its start may take longer than max_wall_s (answered, not killed)
                wait_until(lambda: _identified(ros, window), "an identification on the new worker", timeout=120)
            pid = _worker_pid(ros, stopped[-1] if stopped else None)
            os.kill(pid, signal.SIGSTOP)
            stopped.append(pid)
            box: dict = {}
            t0 = time.monotonic()
            thread = threading.Thread(target=lambda box=box: box.setdefault(
                "res", ros.identify(timeout=wall + 60.0, **window)))
            thread.start()
            wait_until(lambda: ros.diag_value("busy", status="frictionid: identification",
                                              newer_than=time.monotonic()) == "True", "the identification in flight")
            t_call = time.monotonic()
            answer = call()  # a hang here was the bug: the service waited for the worker's pipe
            assert answer.success, (step, answer.message)
            print(f"{step}: answered in {time.monotonic() - t_call:.3f} s with the worker stopped")
            ros.assert_alive(node)
            thread.join(wall + 60.0)
            res = box["res"]
            assert not res.success and res.message.startswith(needle), (step, res.message)
            assert "the identification worker did not stop: killed and restarted" in res.message
            assert "active parameters unchanged" in res.message
            print(f"{step}: ~/identify answered after {time.monotonic() - t0:.2f} s")
        assert _worker_pid(ros, stopped[-1]) not in stopped  # a new worker
        window = _feed(ros, 4.0)  # the reset emptied the buffer
        wait_until(lambda: _identified(ros, window), "an identification on the new worker", timeout=120)
        ros.assert_alive(node)
        assert node.stop() == 0 and "Traceback" not in node.stderr(), node.stderr()
    finally:
        for pid in stopped:
            try:
                os.kill(pid, signal.SIGCONT)  # killed already; never leave one stopped
            except ProcessLookupError:
                pass
        if node.alive():
            node.stop()


@pytest.mark.slow
def test_a_second_node_of_the_same_name_does_not_start(own_ros, workdir):
    ros = own_ros
    first = start_node(workdir, ros, _params_file(workdir, "first"), "first", domain=OWN_DOMAIN)
    others = []
    try:
        second = NodeProcess(workdir, ["--params-file", str(_params_file(workdir, "second"))], "second", OWN_DOMAIN)
        others.append(second)
        assert second.proc.wait(120) == 2
        lines = second.stderr().strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(
            f"frictionid_node: error: another node named /frictionid is running on ROS domain {OWN_DOMAIN}; not "
            "starting a second one (set the parameter unique_name to false to allow it)"), lines
        assert not (workdir / "second").exists() or not any((workdir / "second").iterdir())
        assert first.alive() and ros.call(Trigger, "/frictionid/reset", Trigger.Request()).success
        # told otherwise, it starts
        third = NodeProcess(workdir, ["--params-file", str(_params_file(workdir, "third", unique_name=False))],
                            "third", OWN_DOMAIN)
        others.append(third)
        wait_until(lambda: "configured:" in third.stderr(), "the second node's start", timeout=120, proc=third)
        assert third.stop() == 0
        assert first.stop() == 0 and "Traceback" not in first.stderr(), first.stderr()
    finally:
        for proc in [first, *others]:
            if proc.alive():
                proc.stop()
