"""The node's input path refuses inconsistent JointStates (as the bag reader does): names repeated
(in the first message too) or fields longer than the names, besides messages lacking a joint."""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from sensor_msgs.msg import JointState

from frictionid_ros.inputs import Inputs
from support.node_parts import PERIOD, T0, node_config, stamp_time


def test_inconsistent_messages_are_refused_and_counted(tmp_path):
    cfg = node_config(tmp_path)
    warned = []
    inputs = Inputs(lambda: cfg, warn=warned.append)  # buffers made from the first good message

    def send(k: int, names: list[str], position: list[float], effort: list[float]) -> None:
        m = JointState(name=names, position=position, effort=effort)
        m.header.stamp = stamp_time(T0 + k * PERIOD)
        inputs.joint_state(m, 0)

    send(0, ["a", "a"], [1.0, 2.0], [0.0, 0.0])
    assert inputs.ring is None and inputs.rejected == 1  # no buffer made from repeated names
    send(1, ["a", "b"], [1.0, 2.0], [0.0, 0.0])
    send(2, ["a", "b", "a"], [1.0, 2.0, 3.0], [0.0, 0.0, 0.0])
    send(3, ["a", "b"], [1.0, 2.0, 3.0], [0.0, 0.0])
    send(4, ["b", "a"], [2.0, 1.0], [0.0, 0.0, 5.0])
    send(5, ["a", "b"], [1.0, 2.0], [0.0, 0.0])
    assert inputs.ring.joints == ["a", "b"] and inputs.ring.count == 2
    assert inputs.received == 2 and inputs.rejected == 4
    topic = "ignored message: 'joint_states'"  # the topic as configured
    assert warned == [f"{topic}: message names joint(s) ['a'] more than once (it has ['a', 'a'])",
                      f"{topic}: message names joint(s) ['a'] more than once (it has ['a', 'b', 'a'])",
                      f"{topic}: field 'position' has 3 values for 2 names",
                      f"{topic}: field 'effort' has 3 values for 2 names"]
