"""The node's ROS-free parts fed real message objects (no ROS graph): request parsing, the
input buffers, the data window (selection, effort alignment, gap check), the ~/identify
service logic and the active parameters."""

from __future__ import annotations

import json
import logging
import os
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from builtin_interfaces.msg import Time
    from frictionid_interfaces.srv import Identify
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_ros.config import LIMITS, PARAMETERS, PATH_PARAMETERS, make_config
from frictionid_ros.inputs import Inputs
from frictionid_ros.request import parse_request
from frictionid_ros.service import IdentifyService
from frictionid_ros.store import ActiveParameters, read_results, request_path
from frictionid_ros.worker import JobControl, WorkerProcess
from frictionid_ros.window import window_series

NS = 1_000_000_000
T0 = 1_700_000_000 * NS  # first stamp [ns]
PERIOD = 1_000_000  # 1 kHz [ns]
LOG = logging.getLogger(__name__)
ROOT = Path(__file__).resolve().parents[1]
FV, FC = np.array([2.0, 1.0]), np.array([0.5, 0.3])  # joints a, b


def _cfg(tmp_path, **changes):
    values = {k: v[0] for k, v in PARAMETERS.items()}
    values.update(joints=["a", "b"], system="friction-only", results_file=str(tmp_path / "p.json"), **changes)
    return make_config(values)


def _time(ns: int) -> Time:
    return Time(sec=ns // NS, nanosec=ns % NS)


def _motion(n: int):
    """Stamps [ns], positions, velocities and Coulomb + viscous torques of joints a, b (n, 2)."""
    t = np.arange(n) * 1e-3
    w = 2 * np.pi * np.array([0.8, 1.1])
    q = 0.3 * np.sin(np.outer(t, w))
    v = 0.3 * w * np.cos(np.outer(t, w))
    return T0 + np.arange(n) * PERIOD, q, v, FV * v + FC * np.sign(v)


def _feed(inputs: Inputs, n: int = 1000, skip=(), effort: bool = True, names=("b", "a")):
    """Joint states of _motion (names in another order than the node's joints), stamp k skipped for k in skip."""
    stamps, q, _, tau = _motion(n)
    col = [["a", "b"].index(j) for j in names]
    for k in range(n):
        if k in skip:
            continue
        m = JointState(name=list(names), position=q[k, col].tolist(), effort=tau[k, col].tolist() if effort else [])
        m.header.stamp = _time(int(stamps[k]))
        inputs.joint_state(m, int(stamps[k]))
    return stamps, q, tau


def _inputs(cfg) -> Inputs:
    inputs = Inputs(lambda: cfg, warn=lambda text: None)
    inputs.setup(list(cfg.joints))
    return inputs


def _window(cfg, inputs, **request):
    job = parse_request(Identify.Request(**request), cfg, inputs.joints)
    return window_series(job, cfg, inputs.ring, "/joint_states", inputs.effort_ring, "/effort")


# --------------------------------------------------------------------------- request


def test_request_defaults_and_overrides(tmp_path):
    cfg = _cfg(tmp_path, friction_model="tustin", solver="de", seed=7, window_seconds=2.0)
    job = parse_request(Identify.Request(), cfg, ["a", "b"])
    assert job.joints == ["a", "b"] and job.window_seconds == 2.0 and not job.dry_run
    o = job.options
    assert (o.friction, o.solver, o.seed, o.asymmetric) == ("tustin", "de", 7, False)
    job = parse_request(Identify.Request(joints=["b"], friction_model="coulomb", solver="ls", seed=3, asymmetric=True,
                                         window_start=_time(T0), dry_run=True), cfg, ["a", "b"])
    assert (job.joints, job.options.friction, job.options.seed, job.options.asymmetric) == (["b"], "coulomb", 3, True)
    assert (job.window_seconds, job.start_ns, job.end_ns, job.dry_run) == (0.0, T0, 0, True)
    kwargs = parse_request(Identify.Request(budget=50, population=20), cfg, ["a"]).identify_kwargs("tx40")
    assert kwargs == dict(system="tx40", friction="tustin", asymmetric=False, solver="de", seed=7, generations=50,
                          pop=20)
    seeds = {parse_request(Identify.Request(seed=-1), cfg, ["a"]).options.seed for _ in range(3)}
    assert len(seeds) == 3 and min(seeds) >= 0  # negative: a fresh random seed each time


@pytest.mark.parametrize("fields, needle", [
    (dict(joints=["nope"]), r"unknown joint\(s\) \['nope'\]; buffered joints: \['a', 'b'\]"),
    (dict(joints=["a", "a"]), r"duplicated joint names"),
    (dict(friction_model="lugre"), r"request field 'friction_model': unknown friction model 'lugre'"),
    (dict(solver="simplex"), r"request field 'solver': unknown solver 'simplex'"),
    (dict(population=-1), r"request field 'population' must be an integer >= 0, got -1"),
    (dict(budget=-5), r"request field 'budget' must be an integer >= 0, got -5"),
    (dict(window_seconds=-1.0), r"window_seconds must be >= 0"),
    (dict(window_seconds=float("nan")), r"window_seconds must be >= 0"),
    (dict(window_seconds=2.0, window_end=_time(T0)), r"both window_seconds and window_start/window_end"),
    (dict(window_start=_time(T0), window_end=_time(T0)), r"window_end must be after window_start"),
    (dict(budget=1001), r"request field 'budget' = 1001 is over the node's limit max_budget = 1000"),
    (dict(population=2**31 - 1), r"request field 'population' = 2147483647 is over the node's limit max_population"),
    (dict(window_seconds=61.0), r"window_seconds = 61 s is over the node's limit max_window_seconds = 60 s"),
    (dict(window_start=_time(T0), window_end=_time(T0 + 61 * NS)),
     r"window_start..window_end = 61 s is over the node's limit max_window_seconds = 60 s"),
])
def test_request_errors_name_the_field(tmp_path, fields, needle):
    with pytest.raises(FrictionIdError, match=needle):
        parse_request(Identify.Request(**fields), _cfg(tmp_path), ["a", "b"])


def test_parameters_share_the_validation_and_name_the_parameter(tmp_path):
    assert _cfg(tmp_path, friction_model="stribeck", seed=4).solve.friction == "stribeck"
    with pytest.raises(FrictionIdError, match=r"^parameter 'friction_model': unknown friction model 'lugre'; choose"):
        _cfg(tmp_path, friction_model="lugre")
    with pytest.raises(FrictionIdError, match=r"^parameter 'solver': unknown solver 'x'"):
        _cfg(tmp_path, solver="x")
    with pytest.raises(FrictionIdError, match=r"^parameter 'window_seconds' = 90.0 s is over the limit "
                                              r"max_window_seconds = 60.0 s"):
        _cfg(tmp_path, window_seconds=90.0)
    with pytest.raises(FrictionIdError, match=r"^parameter 'worker_nice' must lie in 0..19, got 20"):
        _cfg(tmp_path, worker_nice=20)
    assert _cfg(tmp_path).results_dir == tmp_path  # the folder of results_file by default
    assert _cfg(tmp_path, results_dir=str(tmp_path / "r")).results_dir == tmp_path / "r"


def test_paths_and_limits_are_start_up_parameters():
    """A client's runtime parameter change can name no file and lift no limit."""
    for name in PATH_PARAMETERS + LIMITS:
        assert PARAMETERS[name][2], f"parameter '{name}' must be read-only"


# --------------------------------------------------------------------------- window


def test_window_selection_by_span_and_stamp_range(tmp_path):
    cfg = _cfg(tmp_path, min_samples=50)
    inputs = _inputs(cfg)
    stamps, q, tau = _feed(inputs)
    sel = _window(cfg, inputs)  # the whole buffer, joints in the node's order
    s = sel.series
    assert len(s) == 1000 and s.joints == ["a", "b"] and sel.notes == [] and s.velocity is None
    assert (sel.start_ns, sel.end_ns) == (stamps[0], stamps[-1]) and s.t[0] == 0.0
    np.testing.assert_array_equal(s.position, q)
    np.testing.assert_array_equal(s.effort, tau)
    np.testing.assert_allclose(s.t, np.arange(1000) * 1e-3, rtol=0, atol=1e-12)
    sel = _window(cfg, inputs, window_seconds=0.5, joints=["b"])  # stamps >= newest - 0.5 s
    assert len(sel.series) == 501 and sel.start_ns == stamps[499] and sel.series.joints == ["b"]
    np.testing.assert_array_equal(sel.series.position[:, 0], q[499:, 1])
    sel = _window(cfg, inputs, window_start=_time(int(stamps[100])), window_end=_time(int(stamps[299])))
    assert (len(sel.series), sel.start_ns, sel.end_ns) == (200, stamps[100], stamps[299])
    with pytest.raises(InputError, match=r"too little data: 11 joint-state samples in the last 0.01 s \(need at least 50\)"):
        _window(cfg, inputs, window_seconds=0.01)


def test_window_refuses_empty_fields_and_nan(tmp_path):
    cfg = _cfg(tmp_path)
    inputs = _inputs(cfg)
    with pytest.raises(InputError, match=r"too little data: no joint states buffered on '/joint_states'"):
        _window(cfg, inputs)
    _feed(inputs, effort=False)
    with pytest.raises(InputError, match=r"empty effort: field 'effort' is empty or shorter than 'name' in 1000 of "
                                         r"1000 .*set the parameter 'effort_topic'"):
        _window(cfg, inputs)
    inputs.clear()
    _feed(inputs, n=300)
    m = JointState(name=["a", "b"], position=[np.nan, 0.0], effort=[0.0, 0.0])
    m.header.stamp = _time(T0 + 300 * PERIOD)
    inputs.joint_state(m, 0)
    with pytest.raises(InputError, match=r"1 NaN/inf samples in field 'position' \(joint 'a'"):
        _window(cfg, inputs)


def test_window_gap_check(tmp_path):
    lost = set(range(100, 130)) | set(range(600, 620))  # 50 of 1000 in 2 gaps: 5 %
    for limit, refused in ((4.9, True), (5.0, False)):
        cfg = _cfg(tmp_path, max_missing_pct=limit)
        inputs = _inputs(cfg)
        _feed(inputs, skip=lost)
        if refused:
            with pytest.raises(InputError, match=r"gaps in the stamps of the joint states in the last 30 s: about 50 of "
                                                 r"1000 samples \(5.00 %\) lost or late \(2 gaps, longest 31.0 ms.*"
                                                 r"max_missing_pct = 4.9 %"):
                _window(cfg, inputs)
        else:
            assert _window(cfg, inputs).notes == ["joint states in the last 30 s: about 50 of 1000 samples (5.00 %) "
                                                  "lost or late (2 gaps, longest 31.0 ms at a 1 ms period)"]


def test_window_effort_topic_by_stamp(tmp_path):
    """A JointState effort topic: interpolated at the joint-state stamps; joint states before its
    first message are dropped with a note."""
    cfg = _cfg(tmp_path, effort_topic="effort", min_samples=100)
    inputs = _inputs(cfg)
    stamps, q, _ = _feed(inputs, effort=False)
    te = stamps[200:] + PERIOD // 2  # starts at joint state 201 (stamp + 0.5 ms), joints reversed
    for k, t_ns in enumerate(te):
        m = JointState(name=["b", "a"], effort=[3.0 - 2e-9 * (t_ns - T0), 1e-9 * (t_ns - T0)])
        m.header.stamp = _time(int(t_ns))
        inputs.effort(m, 0)
    sel = _window(cfg, inputs)
    s = sel.series
    assert len(s) == 799 and sel.start_ns == stamps[201]
    assert sel.notes == ["201 joint-state samples outside the time range of effort topic '/effort' dropped"]
    x = 1e-9 * (stamps[201:] - T0)  # linear efforts are interpolated exactly
    np.testing.assert_allclose(s.effort, np.column_stack([x, 3.0 - 2 * x]), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(s.position, q[201:])
    with pytest.raises(InputError, match=r"too little data: effort topic '/effort' overlaps only 199 of 400 .*need at "
                                         r"least 200"):
        _window(_cfg(tmp_path, effort_topic="effort", min_samples=200), inputs, window_start=_time(int(stamps[0])),
                window_end=_time(int(stamps[399])))


def test_window_unstamped_effort_by_receipt_time(tmp_path):
    """A Float64MultiArray effort topic has no stamp: paired with the joint states by receipt
    time, whatever the joint-state stamps (here a simulated clock at 1000 s)."""
    cfg = _cfg(tmp_path, effort_topic="effort", effort_topic_type="float64_multi_array")
    inputs = _inputs(cfg)
    _, q, _, tau = _motion(500)
    rx = T0 + np.arange(500) * PERIOD + 50_000  # received 50 µs after the effort of the same sample
    for k in range(500):
        m = JointState(name=["a", "b"], position=q[k].tolist())
        m.header.stamp = _time(1000 * NS + k * PERIOD)
        inputs.joint_state(m, int(rx[k]))
        inputs.effort(Float64MultiArray(data=tau[k].tolist()), int(rx[k]) - 50_000)
    sel = _window(cfg, inputs)
    assert len(sel.series) == 499 and sel.start_ns == 1000 * NS  # the last one is after the last effort
    w = 0.95  # effort k + 0.05 (k+1): 50 µs of the 1 ms period toward the next sample
    np.testing.assert_allclose(sel.series.effort, w * tau[:499] + (1 - w) * tau[1:], rtol=0, atol=1e-12)
    inputs.effort(Float64MultiArray(data=[1.0]), 0)
    assert inputs.rejected == 1  # 1 value for 2 joints


# --------------------------------------------------------------------------- service and active parameters


def test_identify_service_answers_and_activates(tmp_path):
    cfg = _cfg(tmp_path, identification_worker="thread")
    inputs = _inputs(cfg)
    published = []
    active = ActiveParameters(cfg.results_file, published.append, log=LOG)
    service = IdentifyService(lambda: cfg, inputs, active, {"joint_states": "/joint_states"}, None, log=LOG)
    answer = service.handle(Identify.Request())
    ok, message, result = answer.ok, answer.message, answer.identified
    assert not ok and message.startswith("too little data") and result is None
    assert (service.last_ok, service.last_status) == (False, message)
    stamps, _, _ = _feed(inputs)
    answer = service.handle(Identify.Request(joints=["b"], dry_run=True))
    ok, message, result = answer.ok, answer.message, answer.identified
    assert ok and "dry run" in message and not published and not cfg.results_file.exists()
    # noise-free data: only the pre-processing (filtered derivatives) moves the estimates, by < 0.1 %
    assert list(result.per_joint) == ["b"] and result.per_joint["b"].params["Fc"] == pytest.approx(FC[1], rel=1e-3)
    answer = service.handle(Identify.Request())
    ok, message, result = answer.ok, answer.message, answer.identified
    assert ok and message.startswith("identified friction-only/coulomb with ls on 1000 samples of ['a', 'b']")
    assert f"saved to {cfg.results_file}" in message and service.last_status == message
    for i, j in enumerate("ab"):
        assert result.per_joint[j].params["Fv"] == pytest.approx(FV[i], rel=1e-3)
    assert (result.window_start_ns, result.window_end_ns, result.window_samples) == (stamps[0], stamps[-1], 1000)
    assert len(published) == 1 and published[0].per_joint.keys() == {"a", "b"}  # the dry run published nothing
    saved = read_results(cfg.results_file)
    assert saved.per_joint["a"].params == result.per_joint["a"].params and saved.window_samples == 1000
    assert json.loads(cfg.results_file.read_text())["friction"] == "coulomb"


def test_active_parameters_merge_save_and_load(tmp_path):
    cfg = _cfg(tmp_path, identification_worker="thread")
    inputs = _inputs(cfg)
    _feed(inputs)
    changes = []
    active = ActiveParameters(cfg.results_file, changes.append, log=LOG)
    service = IdentifyService(lambda: cfg, inputs, active, {"joint_states": "/joint_states"}, None, log=LOG)
    assert service.handle(Identify.Request(joints=["a"])).ok
    assert service.handle(Identify.Request(joints=["b"], friction_model="tustin", solver="lm")).ok
    assert {j: p.friction for j, p in active.results.per_joint.items()} == {"a": "coulomb", "b": "tustin"}
    assert active.save(active.file("")) == (True, f"saved parameters of ['a', 'b'] to {cfg.results_file}")
    other = tmp_path / "other.json"
    ok, message = active.save(other)
    assert ok and other.is_file()
    fresh = ActiveParameters(cfg.results_file, changes.append, log=LOG)
    fresh.restore()  # at start: read quietly
    assert fresh.results.per_joint.keys() == {"a", "b"} and len(changes) == 2
    ok, message = fresh.load(other)
    assert ok and message == f"loaded parameters of ['a', 'b'] from {other}; saved to {cfg.results_file}"
    assert len(changes) == 3
    assert fresh.load(tmp_path / "missing.json") == (False, f"{tmp_path / 'missing.json'}: no such parameters file")
    assert ActiveParameters(tmp_path / "none.json", changes.append, LOG).save(other)[1].startswith("no active")


def test_window_longer_than_the_limit_is_refused(tmp_path):
    cfg = _cfg(tmp_path, max_window_seconds=0.5, min_samples=50)
    inputs = _inputs(cfg)
    stamps, _, _ = _feed(inputs)  # 1 s of data
    assert len(_window(cfg, inputs).series) == 501  # the whole buffer: its newest 0.5 s
    with pytest.raises(InputError, match=r"window of 0.999 s in window_start..window_end is over the limit "
                                         r"max_window_seconds = 0.5 s"):
        _window(cfg, inputs, window_start=_time(int(stamps[0])))  # an open range


# --------------------------------------------------------------------------- results folder, cancel, wall time


def _service_with_parameters(tmp_path, **changes):
    """An IdentifyService (worker thread) on 1 s of data that identified once, and its active parameters."""
    cfg = _cfg(tmp_path, identification_worker="thread", max_budget=100_000, **changes)
    inputs = _inputs(cfg)
    _feed(inputs)
    active = ActiveParameters(cfg.results_file, lambda r: None, log=LOG)
    service = IdentifyService(lambda: cfg, inputs, active, {"joint_states": "/joint_states"}, None, log=LOG)
    assert service.handle(Identify.Request()).ok
    return service, active




def test_request_paths_stay_inside_the_results_folder(tmp_path):
    folder, outside = tmp_path / "results", tmp_path / "outside"
    folder.mkdir()
    outside.mkdir()
    (outside / "notes.txt").write_text("x")
    (folder / "sub").mkdir()
    (folder / "out").symlink_to(outside, target_is_directory=True)
    (folder / "evil.json").symlink_to(outside / "notes.txt")
    (folder / "alias.json").symlink_to(folder / "sub" / "p.json")  # a link inside the folder is fine
    assert request_path(folder, "p.json") == folder / "p.json"
    assert request_path(folder, "sub/p.json") == request_path(folder, str(folder / "sub" / "p.json"))
    assert request_path(folder, "./sub//p.json") == folder / "sub" / "p.json"
    assert request_path(folder, "alias.json") == folder / "sub" / "p.json"
    refused = {str(outside / "notes.txt"): "outside the results folder", "/etc/passwd": "outside the results folder",
               "../outside/notes.txt": "'..'", "sub/../../outside/x.json": "'..'",
               "out/x.json": "symbolic link", "evil.json": "symbolic link", ".": "symbolic link",
               "none/x.json": "no such folder", "a\0b": "NUL"}
    for name, needle in refused.items():
        with pytest.raises(FrictionIdError, match="refused") as err:
            request_path(folder, name)
        assert needle in str(err.value) and f"inside the results folder {folder}" in str(err.value), str(err.value)
    # a folder reached through a symbolic link: its real path is accepted as inside too
    (tmp_path / "link").symlink_to(folder, target_is_directory=True)
    assert request_path(tmp_path / "link", str(folder / "p.json")) == folder / "p.json"


def test_the_node_overwrites_only_its_own_files(tmp_path):
    _, active = _service_with_parameters(tmp_path)
    foreign = tmp_path / "foreign.json"
    for text in ('{"params": {}}', "not json", '{"format": "other/1"}'):
        foreign.write_text(text)
        ok, message = active.save(active.file("foreign.json"))
        assert not ok and "not a parameters file written by this node" in message and foreign.read_text() == text
    (tmp_path / "dir.json").mkdir()
    assert not active.save(active.file("dir.json"))[0]
    assert active.save(active.file("mine.json"))[0] and active.save(active.file("mine.json"))[0]  # its own: again


HUGE = dict(friction_model="tustin", solver="de", population=200, budget=100_000)  # minutes on any machine


def test_cancel_stops_the_identification_and_keeps_the_parameters(tmp_path):
    service, active = _service_with_parameters(tmp_path)
    before = active.results
    control, box = JobControl(), {}
    t = threading.Thread(target=lambda: box.setdefault("answer", service.handle(Identify.Request(**HUGE), control)))
    t.start()
    while control.progress[0] < 2:  # two generations done
        time.sleep(0.01)
    assert service.running is control and service.handle(Identify.Request()).message.startswith("busy")
    assert service.cancel_running("cancelled by the test")
    t.join(30)
    answer = box["answer"]
    assert not answer.ok and answer.cancelled and answer.identified is None
    assert answer.message.startswith("cancelled by the test after") and "active parameters unchanged" in answer.message
    assert active.results is before and service.running is None and not service.cancel_running("again")
    assert service.handle(Identify.Request()).ok  # not stuck busy


def test_wall_time_limit_stops_the_identification(tmp_path):
    service, active = _service_with_parameters(tmp_path, max_wall_s=0.5)
    before = active.results
    answer = service.handle(Identify.Request(**HUGE))
    assert not answer.ok and answer.cancelled and active.results is before
    assert answer.message.startswith("stopped: over the wall-time limit max_wall_s = 0.5 s after"), answer.message


@pytest.mark.slow
def test_worker_process_cancel_kill_and_priority():
    """A job cancelled before the child is ready never runs; the child stops at the optimiser's
    next report; one busy elsewhere (building a TX40 model, no report for seconds) is killed and
    replaced; it runs at the requested niceness."""
    from frictionid_core.io import load

    emps = load(ROOT / "bags" / "emps_estimation").slice(0, 4000)
    worker = WorkerProcess(nice=7)
    try:
        control = JobControl()  # cancelled while the child still starts (imports, warm-up: seconds)
        threading.Timer(0.05, control.cancel, ("early",)).start()
        assert worker.run(emps, dict(system="emps"), control) == ("cancelled", "early")
        assert worker.run(emps, dict(system="emps"))[0] == "ok"
        pid = worker.pid
        assert os.getpriority(os.PRIO_PROCESS, pid) == 7
        control = JobControl()
        threading.Timer(1.0, control.cancel, ("stop",)).start()
        reply = worker.run(emps, dict(system="emps", friction="tustin", solver="de", pop=200, generations=100_000),
                           control)
        assert reply == ("cancelled", "cancelled") and control.progress[0] >= 1 and worker.pid == pid
        tx40 = load(ROOT / "bags" / "tx40_excitation")
        control = JobControl()  # cancelled while the child loads the bag and builds the TX40 model
        threading.Timer(0.2, control.cancel, ("stop",)).start()
        assert worker.run(tx40, dict(system="tx40"), control) == ("cancelled", "stop")
        assert worker.run(emps, dict(system="emps"))[0] == "ok" and worker.pid != pid  # a new child
    finally:
        worker.stop()
