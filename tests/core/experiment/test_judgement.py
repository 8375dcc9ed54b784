"""An experiment's recording fitted on its first part and validated on the rest
(frictionid_core.experiment.fit_and_validate): the window stays in the result's request, so the fit
runs again from the result alone."""

from __future__ import annotations

import numpy as np
import pytest

import frictionid_core as fid
from frictionid_core.excitation.design import FourierTrajectory
from frictionid_core.experiment import fit_and_validate
from frictionid_core.loop import load_robot
from frictionid_core.synthetic import synthesize


@pytest.fixture(scope="module")
def recording():
    robot = load_robot("tx40")
    rng = np.random.default_rng(3)
    n = robot.nv
    traj = FourierTrajectory(list(robot.joints), np.zeros(n), 0.5 * rng.standard_normal((n, 3)),
                             0.5 * rng.standard_normal((n, 3)), 2 * np.pi / 5.0, 10.0, ramp=1.0)
    friction = {j: {"Fv": 1.0 + k, "Fc": 2.0 + 0.5 * k} for k, j in enumerate(robot.joints)}
    series, _ = synthesize(robot, traj, friction="coulomb", friction_params=friction, torque_noise=0.05, rate=500.0)
    return series, friction


def test_fit_on_the_first_part_validate_on_the_rest(recording):
    series, friction = recording
    request = fid.IdentifyRequest(system="tx40", friction="coulomb", solver="ls", known_rigid_body=True)
    result, validation = fit_and_validate(series, request, 7.0)
    assert result.request.window == (None, 7.0)
    # open-loop synthetic data, the law identified is the truth's: the error is the noise's (≤ 1.2 × its floor)
    assert validation["relerr_pct"] <= 1.2 * validation["noise_floor_pct"]
    for j, p in friction.items():  # 0.05 N·m of noise on 7 s: friction within 2 %
        assert result.params[f"{j}/Fc"] == pytest.approx(p["Fc"], rel=0.02)
        assert result.params[f"{j}/Fv"] == pytest.approx(p["Fv"], rel=0.02)
    again = fid.identify(series, fid.IdentifyRequest.from_dict(result.to_dict()["request"]))
    assert again.params == result.params
