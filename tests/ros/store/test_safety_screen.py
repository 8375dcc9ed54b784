"""The node's safety screen and clamp without ROS: every entrance of a parameter set (an
identification, ~/load, the results_file at start) is screened; the clamp is finite by default
and per joint; parameters shaping the torque are range-checked; bad requests and names refused."""

from __future__ import annotations

import json
import math
import re
import warnings

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from builtin_interfaces.msg import Time
    from frictionid_interfaces.srv import Identify
    from sensor_msgs.msg import JointState

from frictionid_core import FrictionIdError
from frictionid_core.safety import Limit
from frictionid_ros.identification import IdentifyService, parse_request
from frictionid_ros.inputs import Inputs
from frictionid_ros.parameters import PARAMETERS, make_config
from frictionid_ros.store import ActiveParameters, JointParams, Results, Screen, read_results, write_results
from support.node_parts import FC, FV, LOG, feed, identification_dict, make_inputs, node_config


def _file(tmp_path, name: str, params: dict) -> str:
    path = tmp_path / name
    path.write_text(json.dumps(identification_dict(["a"], params)))
    return path


def test_load_and_restore_refuse_an_absurd_set_naming_the_parameter_and_the_limit(tmp_path):
    cfg = node_config(tmp_path)
    changes = []
    active = ActiveParameters(cfg.results_file, changes.append, LOG, screen=Screen.of(cfg))
    assert active.load(_file(tmp_path, "good.json", {"Fv": 2.0, "Fc": 0.5, "offset": 0.1}))[0]
    before = cfg.results_file.read_bytes()
    for name, params, needle in [
        ("huge.json", {"Fv": 2.0, "Fc": 1e6, "offset": 0.0},
         "parameter 'a/Fc' = 1e+06 is over the effort limit 100 of 'a' (the node's feedforward_max)"),
        ("negative.json", {"Fv": -1e6, "Fc": 0.5, "offset": 0.0},
         "parameter 'a/Fv' = -1e+06 is negative (a physical magnitude, >= 0)"),
    ]:
        ok, message = active.load(_file(tmp_path, name, params))
        assert not ok and needle in message and message.endswith("active parameters unchanged"), message
        assert "refused by the safety screen" in message
    # 1e300 is refused by the reader of result files already (a value no identification gives)
    ok, message = active.load(_file(tmp_path, "absurd.json", {"Fv": 2.0, "Fc": 1e300, "offset": 0.0}))
    assert not ok and "'params.Fc'" in message and "1e+300" in message, message
    assert len(changes) == 1 and active.results.per_joint["a"].params["Fc"] == 0.5
    assert cfg.results_file.read_bytes() == before  # nothing persisted
    # a results_file that holds such a set (written by hand) is not restored at start
    write_results(cfg.results_file, Results({"a": JointParams("a", "friction-only", "coulomb", False, "ls",
                                                              {"Fv": 2.0, "Fc": 1e300, "offset": 0.0})}))
    errors = []
    log = type("Log", (), {"error": lambda self, text: errors.append(text)})()
    restarted = ActiveParameters(cfg.results_file, changes.append, log, screen=Screen.of(cfg))
    restarted.restore()
    assert restarted.results.per_joint == {} and len(errors) == 1
    assert errors[0].startswith(f"parameters not restored: {cfg.results_file}: refused by the safety screen: "
                                "parameter 'a/Fc' = 1e+300"), errors


def test_a_set_identified_with_a_negated_effort_needs_the_same_drive(tmp_path):
    """A result whose drive negates joint a's effort (a driver's sign opposite to the model's axis):
    refused by a node without that drive (its feed-forward would add to a's friction), accepted by a
    node whose drive_file negates it too."""
    flipped = identification_dict(["a", "b"], {"a/Fv": 2.0, "a/Fc": 0.5, "b/Fv": 1.0, "b/Fc": 0.2})
    flipped["drive"] = {"name": "signs", "joints": ["a", "b"], "side": "joint", "effort_scale": [-1.0, 1.0]}
    (tmp_path / "flipped.json").write_text(json.dumps(flipped))
    plain = ActiveParameters(tmp_path / "plain.json", lambda _: None, LOG,
                             screen=Screen.of(node_config(tmp_path, results_file=str(tmp_path / "plain.json"))))
    ok, message = plain.load(tmp_path / "flipped.json")
    assert not ok and "a: identified with its effort negated but the feed-forward's drive keeps it" in message
    assert "b:" not in message and not plain.results.per_joint, message
    (tmp_path / "signs.yaml").write_text("joints: [a, b]\nside: joint\neffort_scale: [-1, 1]\n")
    cfg = node_config(tmp_path, results_file=str(tmp_path / "signed.json"), drive_file=str(tmp_path / "signs.yaml"))
    signed = ActiveParameters(cfg.results_file, lambda _: None, LOG, screen=Screen.of(cfg))
    ok, message = signed.load(tmp_path / "flipped.json")
    assert ok and signed.results.per_joint["a"].params["Fc"] == 0.5, message
    (tmp_path / "plain_set.json").write_text(json.dumps(identification_dict(["a", "b"], flipped["params"])))
    ok, message = signed.load(tmp_path / "plain_set.json")  # the reverse: identified as logged, the node negates
    assert not ok and "a: identified with its effort as logged but the feed-forward's drive negates it" in message


def test_an_identification_keeps_its_data_limits_and_a_refused_one_changes_nothing(tmp_path):
    cfg = node_config(tmp_path, identification_worker="thread")
    inputs = make_inputs(cfg)
    feed(inputs)
    active = ActiveParameters(cfg.results_file, lambda r: None, LOG, screen=Screen.of(cfg))
    service = IdentifyService(lambda: cfg, inputs, active, {"joint_states": "/joint_states"}, None, LOG)
    answer = service.handle(Identify.Request())
    assert answer.ok, answer.message
    # the data's limits: 2 × the largest |effort| (FV·v + FC·sign v at the largest speed) and speed
    speed = 0.3 * 2 * np.pi * np.array([0.8, 1.1])
    for k, j in enumerate("ab"):
        limit = active.results.per_joint[j].limit
        assert limit.effort == pytest.approx(2 * (FV[k] * speed[k] + FC[k]), rel=1e-3)
        assert limit.speed == pytest.approx(2 * speed[k], rel=1e-2)
    saved = read_results(cfg.results_file)  # kept in the results file
    assert saved.per_joint["a"].limit == active.results.per_joint["a"].limit
    # the clamp of each joint: its effort limit (below feedforward_max = 100)
    assert active.screen.clamp(["a", "b"], active.results.per_joint).tolist() == [
        active.results.per_joint[j].limit.effort for j in "ab"]
    assert active.screen.clamp(["a", "c"], active.results.per_joint)[1] == cfg.feedforward_max
    # gate_max_abs below the identified Fv: the set is refused, named, and nothing changes
    strict = node_config(tmp_path, identification_worker="thread", gate_max_abs=1.0)
    active_before = active.results
    service = IdentifyService(lambda: strict, inputs, ActiveParameters(cfg.results_file, lambda r: None, LOG,
                                                                       screen=Screen.of(strict)), {"joint_states": "x"},
                              None, LOG)
    answer = service.handle(Identify.Request())
    assert not answer.ok and "refused by the safety screen: parameter 'a/Fv' = 2" in answer.message
    assert "over the limit |value| <= 1" in answer.message and answer.message.endswith("active parameters unchanged")
    assert active.results is active_before


def test_the_feed_forward_is_clamped_per_joint(tmp_path):
    cfg = node_config(tmp_path, feedforward_max=5.0)
    per_joint = {"a": JointParams("a", "friction-only", "coulomb", False, "ls", {"Fv": 100.0, "Fc": 4.0}),
                 "b": JointParams("b", "friction-only", "coulomb", False, "ls", {"Fv": 100.0, "Fc": 1.0},
                                  limit=Limit(3.0, 1.0, "data"))}
    screen = Screen.of(cfg)
    inputs = Inputs(lambda: cfg, LOG.warning, lambda joints, per: screen.clamp(joints, per))
    inputs.setup(["a", "b"])
    inputs.set_params(per_joint)
    for v in ([10.0, 10.0], [-10.0, -10.0], [0.01, 0.001]):
        torque = inputs.ff.torque(np.array(v))
        assert np.all(np.abs(torque) <= [5.0, 3.0]), torque
    assert inputs.ff.torque(np.array([10.0, -10.0])).tolist() == [5.0, -3.0]


def test_parameters_that_shape_the_torque_are_bounded_and_finite(tmp_path):
    base = {name: p.default for name, p in PARAMETERS.items()}
    base.update(results_file=str(tmp_path / "p.json"))
    assert make_config(base).feedforward_max == 100.0  # a clamp by default
    for name, value, needle in [("smoothing_eps", math.inf, "must lie in [0, 1]"),
                                ("smoothing_eps", 2.0, "must lie in [0, 1]"),
                                ("feedforward_max", 0.0, "must lie in (0, 1e+06)"),
                                ("feedforward_max", math.inf, "must lie in (0, 1e+06)"),
                                ("feedforward_ramp_s", math.inf, "must lie in [0, 600]"),
                                ("feedforward_rate_hz", math.inf, "must lie in [0, 10000]"),
                                ("gate_max_abs", math.inf, "must lie in (0, 1e+09)"),
                                ("max_wall_s", math.inf, "must be a finite number"),
                                ("min_samples", 0, "must be >= 3")]:
        with pytest.raises(FrictionIdError, match=rf"parameter '{name}' {re.escape(needle)}"):
            make_config({**base, name: value})


def _stamp(sec: int, nanosec: int) -> Time:
    return Time(sec=sec, nanosec=nanosec)


def test_requests_and_joint_names_are_checked(tmp_path):
    cfg = node_config(tmp_path)
    with pytest.raises(FrictionIdError, match=r"request field 'window_start' = 5 s \+ 4000000000 ns is not a time "
                                              r"stamp \(sec >= 0, 0 <= nanosec < 1000000000\)"):
        parse_request(Identify.Request(window_start=_stamp(5, 4_000_000_000)), cfg, ["a", "b"])
    huge = "j" * 1_000_000
    with pytest.raises(FrictionIdError) as e:
        parse_request(Identify.Request(joints=[huge]), cfg, ["a", "b"])
    assert len(str(e.value)) < 300 and "(1000000 characters)" in str(e.value)
    values = {name: p.default for name, p in PARAMETERS.items()}
    values.update(results_file=str(tmp_path / "p.json"))
    with pytest.raises(FrictionIdError, match="parameter 'joints': joint name 'xxx.*longer than 256 characters"):
        make_config({**values, "joints": ["a", "x" * 300]})
    # the first joint state names the joints: an empty or a huge name is refused, shortened in the log
    warned = []
    empty = make_config(values)
    inputs = Inputs(lambda: empty, warned.append)
    for names in (["", "b"], [huge]):
        inputs.joint_state(JointState(name=names, position=[0.0] * len(names)), 0)
    assert inputs.ring is None and inputs.rejected == 2
    assert "an empty joint name in ['', 'b']" in warned[0] and len(warned[1]) < 300, warned


def test_a_deeply_nested_file_is_one_line(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(FrictionIdError, match="nested too deeply"):
        read_results(path)
    active = ActiveParameters(tmp_path / "p.json", lambda r: None, LOG)
    ok, message = active.load(path)
    assert not ok and "nested too deeply" in message
