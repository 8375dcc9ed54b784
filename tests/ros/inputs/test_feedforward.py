"""The feed-forward torque equals the core's friction model, joint by joint."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.friction import get_model
from frictionid_ros.inputs import FeedForward
from frictionid_ros.store import JointParams


def test_feedforward_equals_the_core_model_per_joint():
    ff = FeedForward(["a", "b", "c", "d"], eps=0.02)
    params = {
        "a": JointParams("a", "x", "coulomb", False, "ls", {"Fv": 1.0, "Fc": 0.5}),
        "b": JointParams("b", "x", "tustin", True, "de", {"Fv_pos": 1, "Fc_pos": 0.4, "Fs_pos": 0.6, "vs_pos": 0.01,
                                                          "Fv_neg": 2, "Fc_neg": 0.3, "Fs_neg": 0.5, "vs_neg": 0.02}),
        "c": JointParams("c", "x", "coulomb", False, "ls", {"Fv": 3.0, "Fc": 0.1, "offset": 9.0}),
    }
    assert ff.set_params(params) == [] and ff.active == ("a", "b", "c")
    v = np.array([0.05, -0.01, -0.3, 1.0])
    got = ff.torque(v)
    for i, j in enumerate("abc"):
        model, theta = params[j].friction_vector()
        assert got[i] == pytest.approx(model.torque(np.array(theta), v[i : i + 1], eps=0.02)[0], rel=1e-14)
    assert got[3] == 0.0  # no parameters: no torque
    assert got[2] == pytest.approx(get_model("coulomb").torque([3.0, 0.1], [-0.3], eps=0.02)[0])  # no offset
    assert ff.torque(np.array([np.nan, 0.0, 0.0, 0.0]))[0] == 0.0  # unknown velocity: no torque


T0_NS = 1_700_000_000_000_000_000
LUGRE = {"Fv": 0.5, "Fc": 2.0, "Fs": 3.0, "vs": 0.05, "sigma0": 2000.0, "sigma1": 5.0}


def test_a_dynamic_law_is_fed_forward_with_its_states_at_the_input_rate():
    """LuGre on joint a, Coulomb on b: stepped sample by sample (advance, then torque as the node
    does), the feed-forward is the core's integration of the law along the same samples; the
    states restart at their sliding values after a gap and on new parameters."""
    ff = FeedForward(["a", "b"])
    params = {"a": JointParams("a", "x", "lugre", False, "lm", dict(LUGRE)),
              "b": JointParams("b", "x", "coulomb", False, "ls", {"Fv": 1.0, "Fc": 0.5})}
    assert ff.set_params(params) == []
    t = np.arange(0.0, 2.0, 1e-3)
    v = 0.2 * np.sin(2 * np.pi * t)  # reversals at 0.5 s and 1.5 s
    got = []
    for k in range(t.size):
        vk = np.array([v[k], v[k]])
        ff.advance(vk, T0_NS + k * 1_000_000)
        got.append(ff.torque(vk).copy())
    got = np.array(got)
    model = get_model("lugre")
    expected = model.torque(np.array([LUGRE[n] for n in model.names]), v, t=t)
    np.testing.assert_allclose(got[:, 0], expected, rtol=0, atol=1e-12)
    assert got[:, 1] == pytest.approx(get_model("coulomb").torque([1.0, 0.5], v))
    hysteresis = got[250:750, 0]  # a reversal's pre-sliding: smooth, no sign jump
    assert np.max(np.abs(np.diff(hysteresis))) < 0.1
    sliding = -(LUGRE["Fc"] + (LUGRE["Fs"] - LUGRE["Fc"]) * np.exp(-(0.1 / LUGRE["vs"]) ** 2)) - 0.5 * 0.1
    ff.advance(np.array([-0.1, 0.0]), T0_NS + 2_500_000_000)  # after a 0.5 s gap: the sliding state
    assert ff.torque(np.array([-0.1, 0.0]))[0] == pytest.approx(sliding, rel=1e-9)
    ff.set_params(params)  # new parameters, no sample yet: the sliding state of the velocity (0 at rest)
    assert ff.torque(np.array([0.0, 0.0]))[0] == 0.0
    ff.advance(np.array([np.nan, 0.0]), T0_NS + 2_501_000_000)  # unknown velocity: restarted at rest
    assert ff.torque(np.array([0.0, 0.0]))[0] == 0.0


def test_a_load_dependent_level_rises_with_the_measured_load():
    """Fc_load fed forward on the joint side: the Coulomb level Fc + Fc_load·|τ_rigid|, τ_rigid the
    measured effort less the friction fed forward; Fc alone without a measured effort; not under a
    drive (named)."""
    ff = FeedForward(["a", "b"])
    params = {"a": JointParams("a", "tx40", "coulomb", False, "ls", {"Fv": 1.0, "Fc": 0.5, "Fc_load": 0.04}),
              "b": JointParams("b", "tx40", "coulomb", False, "ls", {"Fv": 2.0, "Fc": 1.0})}
    assert ff.set_params(params) == []
    v = np.array([1.0, -0.5])
    np.testing.assert_allclose(ff.torque(v), [1.5, -2.0])  # no effort measured yet: Fc alone
    ff.effort[:] = [21.5, -7.0]  # joint a: 20 N·m of rigid-body torque beside its 1.5 of friction
    np.testing.assert_allclose(ff.torque(v), [1.5 + 0.04 * 20.0, -2.0], rtol=1e-12)
    np.testing.assert_allclose(ff.torque(-v), [-1.5 - 0.04 * 23.0, 2.0], rtol=1e-12)  # |21.5 − (−1.5)|
    ff.effort[:] = np.nan
    np.testing.assert_allclose(ff.torque(v), [1.5, -2.0])


def test_under_a_drive_a_load_dependent_level_is_named_as_not_fed_forward():
    from frictionid_core import load_drive

    drive = load_drive("tx40")
    ff = FeedForward(list(drive.joints), drive=drive)
    per_joint = {j: JointParams(j, "tx40", "coulomb", False, "ls", {"Fv": 1.0, "Fc": 0.5}) for j in drive.joints}
    per_joint["joint_1"] = JointParams("joint_1", "tx40", "coulomb", False, "ls", {"Fv": 1.0, "Fc": 0.5,
                                                                                  "Fc_load": 0.04})
    problems = ff.set_params(per_joint)
    assert len(problems) == 1 and "Fc_load 0.04" in problems[0] and "not fed forward under a drive" in problems[0]
