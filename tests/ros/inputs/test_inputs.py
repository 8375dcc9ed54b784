"""The node's input path refuses inconsistent JointStates (as the bag reader does): names repeated
(in the first message too) or fields longer than the names, besides messages lacking a joint."""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl
    from sensor_msgs.msg import JointState

from frictionid_ros.inputs import Inputs
from support.node_parts import PERIOD, T0, make_inputs, node_config, stamp_time


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


def test_a_dynamic_law_steps_its_states_with_the_reference_velocity(tmp_path):
    """velocity_source: reference — the LuGre feed-forward's states follow the reference messages
    (at their rate), not the measured joint states: its torque is the core's law integrated along
    the reference velocities and stamps."""
    import numpy as np

    from frictionid_core.friction import get_model
    from frictionid_ros.store import JointParams

    cfg = node_config(tmp_path, velocity_source="reference")
    inputs = make_inputs(cfg)
    lugre = {"Fv": 0.5, "Fc": 2.0, "Fs": 3.0, "vs": 0.05, "sigma0": 2000.0, "sigma1": 5.0}
    params = {j: JointParams(j, "friction-only", "lugre", False, "lm", dict(lugre)) for j in "ab"}
    assert inputs.set_params(params) == []
    n = 800
    v = 0.2 * np.sin(2 * np.pi * np.arange(n) * 2e-3)  # a reference at 500 Hz with a reversal at 0.5 s
    got = []
    for k in range(n):
        measured = JointState(name=["a", "b"], position=[0.0, 0.0], velocity=[5.0, -5.0])  # ignored for the states
        measured.header.stamp = stamp_time(T0 + k * 2 * PERIOD)
        inputs.joint_state(measured, 0)
        ref = JointState(name=["a", "b"], velocity=[v[k], -v[k]])
        ref.header.stamp = stamp_time(T0 + k * 2 * PERIOD)
        assert inputs.reference(ref)
        got.append(inputs.ff.torque(inputs.v).copy())
    model = get_model("lugre")
    expected = model.torque(np.array([lugre[p] for p in model.names]), v, t=np.arange(n) * 2 * PERIOD * 1e-9)
    np.testing.assert_allclose(np.array(got)[:, 0], expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.array(got)[:, 1], -expected, rtol=0, atol=1e-9)
