"""The feed-forward torque equals the core's friction model, joint by joint."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.friction import get_model
from frictionid_ros.feedforward import FeedForward
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
