"""The node's parameters declared on a real rclpy node from their declarations: descriptors with the
description, read-only flag and range (rclpy refuses a number outside it), a start-up override out
of range reported in one line naming the parameter, runtime changes validated together."""

from __future__ import annotations

import math
import warnings

import pytest

from support.ros_harness import private_domain

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    import rclpy
    from rcl_interfaces.msg import SetParametersResult
    from rclpy.parameter import Parameter

from frictionid_core import FrictionIdError
from frictionid_ros.parameters import PARAMETERS, changed_config, declare_parameters

pytestmark = [pytest.mark.ros, pytest.mark.filterwarnings("ignore::DeprecationWarning")]
# a domain of its own, away from the nodes named frictionid the other tests start (an id above 232 made
# Fast DDS end the pytest process with status 1: "Calculated port number is too high")
NODES_DOMAIN = private_domain()


@pytest.fixture
def make_node():
    """Factory of plain rclpy nodes named like the frictionid node (``overrides``: name → value, as
    from a parameters file); every node and its context are closed after the test."""
    made = []

    def make(**overrides):
        ctx = rclpy.Context()
        rclpy.init(context=ctx, domain_id=NODES_DOMAIN)
        node = rclpy.create_node("frictionid", context=ctx, start_parameter_services=False,
                                 parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
        made.append((node, ctx))
        return node

    yield make
    for node, ctx in made:
        node.destroy_node()
        rclpy.shutdown(context=ctx)


def test_descriptors_carry_the_declarations(make_node):
    node = make_node()
    cfg = declare_parameters(node)
    assert cfg.worker_nice == 19 and cfg.solve.friction == "coulomb"
    assert all(node.has_parameter(name) for name in PARAMETERS)
    nice, buffer, window, qos, holdout, joints = (node.describe_parameter(name) for name in (
        "worker_nice", "buffer_seconds", "window_seconds", "qos", "online_holdout", "joints"))
    assert nice.read_only and [(r.from_value, r.to_value, r.step) for r in nice.integer_range] == [(0, 19, 1)]
    assert buffer.description == "length of the joint-state ring buffer [s]" and buffer.additional_constraints == "> 0"
    assert [(r.from_value, r.to_value) for r in buffer.floating_point_range] == [(0.0, math.inf)]
    assert not window.read_only and window.floating_point_range[0].from_value == 0.0
    assert qos.additional_constraints == "one of sensor_data, reliable" and not qos.floating_point_range
    assert [(r.from_value, r.to_value) for r in holdout.floating_point_range] == [(0.0, 1.0)]
    assert joints.type == Parameter.Type.STRING_ARRAY.value
    assert node.describe_parameter("realtime_priority").dynamic_typing


def test_a_start_up_value_out_of_range_is_one_line_naming_the_parameter(make_node):
    for name, value, message in (
            ("worker_nice", 20, "parameter 'worker_nice' must lie in 0..19, got 20"),
            ("buffer_seconds", -1.0, "parameter 'buffer_seconds' must be > 0, got -1.0"),
            ("buffer_seconds", 0.0, "parameter 'buffer_seconds' must be > 0, got 0.0"),  # rclpy allows the bound
            ("qos", "fast", "parameter 'qos': unknown qos 'fast'; choose one of sensor_data, reliable")):
        with pytest.raises(FrictionIdError) as e:
            declare_parameters(make_node(**{name: value}))
        assert str(e.value) == message


def test_runtime_changes_are_held_to_the_range_and_to_the_other_parameters(make_node):
    node = make_node(window_seconds=5.0)
    box = {"cfg": declare_parameters(node)}

    def on_set(params):
        try:
            box["cfg"] = changed_config(node, box["cfg"], params)
        except FrictionIdError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(on_set)
    [refused] = node.set_parameters([Parameter("window_seconds", value=-1.0)])  # by rclpy: the range
    assert not refused.successful and "out of range" in refused.reason
    [refused] = node.set_parameters([Parameter("window_seconds", value=90.0)])  # by the check across parameters
    assert not refused.successful and refused.reason.startswith("parameter 'window_seconds' = 90.0 s is over the limit")
    [refused] = node.set_parameters([Parameter("worker_nice", value=5)])
    assert not refused.successful and "read-only" in refused.reason
    results = node.set_parameters([Parameter("friction_model", value="stribeck"),
                                   Parameter("window_seconds", value=0.0)])
    assert [r.successful for r in results] == [True, True]
    cfg = box["cfg"]
    assert (cfg.solve.friction, cfg.window_seconds, cfg.worker_nice) == ("stribeck", 0.0, 19)
