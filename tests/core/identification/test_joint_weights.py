"""Weighted least squares over the joints: each joint's rows weighted by its own residual σ, so a
wrist of 0.7 N·m counts beside a shoulder of 11 N·m (the little arm of tests/support/little_arm.py)."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.excitation.design import FourierTrajectory, fit_to_limits
from frictionid_core.identification import IdentifyRequest, build_model, identify
from frictionid_core.identification.joint_weights import joint_sigmas, unweighted_model, weighted_model
from frictionid_core.identification.plan import Holds, plan_fit
from frictionid_core.robots import load_urdf
from frictionid_core.synthetic import synthesize
from frictionid_core.systems import as_system
from support.little_arm import ARM, FINGER, FRICTION, URDF

NOISE = {"shoulder": 0.05, "elbow": 0.02, "wrist": 0.001}  # N·m: each about 0.2–0.5 % of its joint's RMS torque
HOLD = {"finger_l": FINGER, "finger_r": FINGER}


def arm_model(series, urdf):
    """The unweighted Coulomb model of ``series`` on the arm, the fingers and the pan held."""
    system = as_system(f"urdf:{urdf}")
    return build_model(plan_fit([series], system, None, Holds(dict(HOLD), True)), system, "coulomb", False)


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    path = tmp_path_factory.mktemp("weights") / "little_arm.urdf"
    path.write_text(URDF)
    return path


def recording(urdf, seed: int, noise: dict[str, float] = NOISE):
    """The arm on a Fourier excitation at 500 Hz, white effort noise of ``noise`` (N·m) per joint."""
    robot = load_urdf(urdf)
    rng = np.random.default_rng(seed)
    a, b, start = np.zeros((robot.nv, 3)), np.zeros((robot.nv, 3)), np.zeros(robot.nv)
    for k, j in enumerate(robot.joints):
        start[k] = FINGER if j.startswith("finger") else (0.0 if j == "pan" else 0.3)
        if j in ARM:
            a[k], b[k] = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
    traj = fit_to_limits(robot, FourierTrajectory(list(robot.joints), start, a, b, 2 * np.pi / 4, 12.0), 0.2)
    params = {j: {"Fv": fv, "Fc": fc} for j, (fv, fc) in FRICTION.items()}
    series, _ = synthesize(robot, traj, friction="coulomb", friction_params=params, torque_noise=0.0, rate=500.0,
                           seed=seed)
    series = series.select(ARM)
    sigma = np.array([noise[j] for j in series.joints])
    series.effort = series.effort + rng.standard_normal(series.effort.shape) * sigma
    return series


def test_each_joints_sigma_follows_its_own_noise(arm):
    """σ_j of the closed-form Coulomb fit follows each joint's effort noise (the model is exact here;
    the noise spans 50 ×, the decimation filter at each joint's cut-off passes 30–45 % of it); the
    weighted model's fit rows are the unweighted ones times 1/σ_j relative to the noisiest, its
    metric rows stay the recorded effort in N·m."""
    model = arm_model(recording(arm, 1), arm)
    sigma = joint_sigmas(model)
    ratio = sigma / np.array([NOISE[j] for j in model.obs.joints])
    assert np.all(ratio < 1.0) and ratio.max() < 1.6 * ratio.min(), ratio
    weighted = weighted_model(model)
    w = weighted.obs.joint_weight
    assert w == pytest.approx(sigma.max() / sigma, rel=1e-12) and w.min() == 1.0
    nd = model.obs.n_samples
    assert weighted.obs.y == pytest.approx(model.obs.y * np.repeat(w, nd), rel=1e-12)
    assert weighted.obs.metric.y is model.obs.metric.y
    assert unweighted_model(weighted).obs.y == pytest.approx(model.obs.y, rel=1e-12, abs=1e-15)
    assert weighted_model(weighted) is weighted


@pytest.mark.parametrize("seed", [1, 3])
def test_a_small_joint_is_fitted_to_its_own_noise_beside_a_noisy_large_one(arm, seed):
    """A shoulder current of 0.5 N·m noise (5 % of its torque) beside a wrist of 0.001 N·m: fitted
    in N·m, the shoulder's noise reaches the wrist through the hand's inertials (its Fc 0.9–1.5 %
    off, the elbow's up to 1.3 %); each joint weighted by its own σ, the wrist's Fv and Fc are within
    0.3 % and the elbow's within 0.6 %; the relative error stays in N·m (4.3 %, as fitted in N·m)."""
    noisy = {"shoulder": 0.5, "elbow": 0.1, "wrist": 0.001}
    r = identify(recording(arm, seed, noisy), IdentifyRequest(system=f"urdf:{arm}", hold=HOLD, hold_missing=True))
    for j, tol in (("wrist", 0.003), ("elbow", 0.006), ("shoulder", 0.05)):
        assert r.params[f"{j}/Fv"] == pytest.approx(FRICTION[j][0], rel=tol), j
        assert r.params[f"{j}/Fc"] == pytest.approx(FRICTION[j][1], rel=tol), j
    assert 3.5 < r.metrics["relerr_pct"] < 5.5  # in N·m: the shoulder's noise (weighted rows would read ~0.3 %)
