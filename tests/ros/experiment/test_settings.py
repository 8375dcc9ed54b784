"""A ``~/run_experiment`` goal validated into settings, and the bag recorder (no node started)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from frictionid_interfaces.action import RunExperiment
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

import frictionid_core as fid
from frictionid_core import FrictionIdError
from frictionid_ros.experiment import BagRecorder, parse_goal
from frictionid_ros.parameters import make_config

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
JOINTS = [f"joint_{k}" for k in range(1, 7)]


@pytest.fixture(scope="module")
def cfg(tmp_path_factory):
    return make_config({"system": "tx40", "joints": JOINTS, "friction_model": "coulomb",
                        "results_file": str(tmp_path_factory.mktemp("r") / "p.json")})


def test_zeros_take_the_defaults(cfg):
    s = parse_goal(RunExperiment.Goal(), cfg, JOINTS)
    assert (s.interface, s.topic, s.rate_hz) == ("trajectory", "/joint_trajectory_controller/joint_trajectory", 100.0)
    assert (s.design.duration_s, s.design.harmonics, s.design.period_s, s.design.evals, s.design.margin) == (
        20.0, 5, 10.0, 1500, 0.05)
    assert s.thresholds.to_dict() == {"tracking_rad": 0.05, "effort_ratio": 1.0, "silence_s": 0.25}
    assert (s.validation_share, s.max_floor_ratio, s.max_relerr_pct, s.approach_speed) == (0.3, 1.5, 0.0, 0.2)
    assert s.request.system == "tx40" and s.request.friction == "coulomb" and s.request.joints == tuple(JOINTS)
    stream = parse_goal(RunExperiment.Goal(command_interface="position"), cfg, JOINTS)
    assert (stream.topic, stream.rate_hz) == ("/forward_position_controller/commands", 250.0)


def test_the_identification_fields_go_over_the_node_parameters(cfg):
    s = parse_goal(RunExperiment.Goal(friction_model="tustin", solver="lm", cutoff_hz=30.0, min_speed=0.2,
                                      reversal_periods=1.0), cfg, JOINTS)
    assert s.request.friction == "tustin" and s.request.solver.method == "lm"
    assert s.request.preprocessing.changes() == {"cutoff_hz": 30.0, "min_speed": 0.2, "reversal_periods": 1.0}


@pytest.mark.parametrize(("fields", "message"), [
    ({"command_interface": "velocity"}, "goal field 'command_interface' = 'velocity': choose one of trajectory"),
    ({"command_topic": "/a b"}, "goal field 'command_topic' = '/a b' is not a topic name"),
    ({"max_tracking_error": -1.0}, "goal field 'max_tracking_error' must be a finite number >= 0"),
    ({"duration_s": 1e6}, "goal field 'duration_s' = 1e+06 must lie in [0.5, 600]"),
    ({"validation_share": 1.5}, "goal field 'validation_share': the validation share must be a fraction in (0, 1)"),
    ({"friction_model": "nope"}, "goal field 'friction_model'"),
    ({"budget": 10**9}, "goal field 'budget' = 1000000000 is over the node's limit max_budget"),
])
def test_a_bad_field_is_one_line_naming_it(cfg, fields, message):
    with pytest.raises(FrictionIdError) as exc:
        parse_goal(RunExperiment.Goal(**fields), cfg, JOINTS)
    assert str(exc.value).startswith(message) and "\n" not in str(exc.value)


def test_the_recorder_writes_the_messages_rclpy_serialized(tmp_path):
    """What the node's input thread hands over (rclpy's CDR bytes), read back by frictionid's loader."""
    bag = BagRecorder(tmp_path / "bag", "/joint_states")
    t0 = 1_700_000_000_000_000_000
    for k in range(50):
        msg = JointState(name=["a", "b"], position=[0.01 * k, -0.02 * k], velocity=[1.0, -2.0], effort=[0.5, k])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t0 + k * 1_000_000, 1_000_000_000)
        bag.put(t0 + k * 1_000_000, serialize_message(msg))
        if k % 20 == 0:
            bag.flush()
    assert bag.close() == tmp_path / "bag" and bag.count == 50
    bag.put(t0, b"after the close: dropped")
    series = fid.load(tmp_path / "bag")
    assert series.joints == ["a", "b"] and len(series.t) == 50
    np.testing.assert_allclose(series.t, np.arange(50) * 1e-3, atol=1e-12)
    np.testing.assert_allclose(series.effort[:, 1], np.arange(50))
    with pytest.raises(FrictionIdError, match="already exists"):
        BagRecorder(tmp_path / "bag", "/joint_states")
