"""A commanded motion as trajectory points (frictionid_core.experiment.motion): the quintic Hermite
interpolation of a JointTrajectoryController, the approach within the limits, and the motion screen
of the safety package."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core import FrictionIdError, InputError
from frictionid_core.excitation import robot_limits
from frictionid_core.excitation.design import FourierTrajectory
from frictionid_core.experiment import Motion, approach, approach_duration, quintic, sampled
from frictionid_core.loop import load_robot
from frictionid_core.safety import screen_motion


@pytest.fixture(scope="module")
def tx40():
    return load_robot("tx40")


def fourier(joints, duration=4.0, scale=1.0):
    rng = np.random.default_rng(1)
    n = len(joints)
    return FourierTrajectory(list(joints), np.zeros(n), scale * 0.3 * rng.standard_normal((n, 3)),
                             scale * 0.3 * rng.standard_normal((n, 3)), 2 * np.pi / 4.0, duration, ramp=1.0)


def test_quintic_meets_both_ends_and_is_a_polynomial():
    p0, v0, a0, p1, v1, a1, h = 0.2, -1.0, 3.0, 1.1, 0.5, -2.0, 0.7
    for s, want in ((0.0, (p0, v0, a0)), (1.0, (p1, v1, a1))):
        np.testing.assert_allclose(quintic(p0, v0, a0, p1, v1, a1, h, s), want, rtol=0, atol=1e-12)
    s = np.linspace(0, 1, 201)
    q, v, a = quintic(p0, v0, a0, p1, v1, a1, h, s)
    # derivatives consistent with the position (central differences on a fine grid, O(ds²))
    ds = s[1] - s[0]
    np.testing.assert_allclose(np.gradient(q, ds * h)[2:-2], v[2:-2], rtol=0, atol=1e-3)
    np.testing.assert_allclose(np.gradient(v, ds * h)[2:-2], a[2:-2], rtol=0, atol=1e-2)


def test_points_every_10_ms_give_back_the_excitation(tx40):
    """A smooth excitation sampled at 100 Hz and interpolated again: within 1e-9 rad (a 5-harmonic
    series of period 4 s: the quintic's error is h⁶·q⁽⁶⁾/… ≈ 1e-11)."""
    traj = fourier(tx40.joints)
    m = sampled(traj, list(tx40.joints), 100.0)
    assert m.duration == pytest.approx(traj.duration) and len(m.t) == 401
    t = np.linspace(0.0, traj.duration, 1777)
    q, qd, qdd = traj.evaluate(t)
    a, b, c = m.at(t)
    assert np.abs(a - q).max() < 1e-9 and np.abs(b - qd).max() < 1e-7 and np.abs(c - qdd).max() < 1e-5


def test_a_motion_holds_its_ends_and_chains(tx40):
    traj = fourier(tx40.joints)
    m = sampled(traj, list(tx40.joints), 100.0)
    before, after = m.at([-1.0]), m.at([m.duration + 5.0])
    np.testing.assert_allclose(before[0][0], m.start, atol=1e-12)
    np.testing.assert_allclose(after[0][0], m.end, atol=1e-12)
    np.testing.assert_allclose(after[1][0], 0.0, atol=1e-9)  # the ramped excitation ends at rest
    both = approach(list(tx40.joints), m.end, m.start, 2.0).then(m)
    assert both.duration == pytest.approx(2.0 + m.duration)
    np.testing.assert_allclose(both.at([1.0])[0][0], 0.5 * (m.end + m.start), atol=1e-9)  # quintic: half-way
    with pytest.raises(InputError, match="start at 0 and increase"):
        Motion(["a"], [0.0, 0.0], [[0], [1]], [[0], [0]], [[0], [0]])


def test_the_approach_stays_within_its_share_of_the_limits(tx40):
    limits = robot_limits(tx40)
    q0, q1 = np.zeros(6), np.array([1.0, -0.5, 0.8, 2.0, -1.0, 3.0])
    for speed in (0.1, 0.2, 0.5):
        seconds = approach_duration(q0, q1, limits.velocity, limits.acceleration, speed)
        move = approach(list(tx40.joints), q0, q1, seconds, 1000.0)
        # at the bound on the binding joint, within it elsewhere (the quintic's peaks are exact)
        v = np.abs(move.qd).max(axis=0) / limits.velocity
        a = np.abs(move.qdd).max(axis=0) / limits.acceleration
        assert max(v.max(), a.max()) == pytest.approx(speed, rel=1e-3)
        np.testing.assert_allclose(move.end, q1, atol=1e-12)
    assert approach_duration(q0, q0, limits.velocity, limits.acceleration, 0.2) == 1.0  # at least 1 s
    with pytest.raises(InputError, match="approach speed"):
        approach_duration(q0, q1, limits.velocity, limits.acceleration, 0.0)


def test_the_screen_refuses_a_motion_beyond_a_limit_naming_it(tx40):
    limits = robot_limits(tx40)
    q0 = np.zeros(6)
    ok = approach(list(tx40.joints), q0, np.full(6, 0.3), 2.0)
    report = screen_motion(tx40, limits, ok)
    assert report["ok"] and report["max_ratio"]["velocity"] < 0.95
    fast = approach(list(tx40.joints), q0, np.array([0.0, 0.0, 0.0, 0.0, 0.0, 3.0]), 0.5)  # joint_6: 11 rad/s
    with pytest.raises(FrictionIdError, match=r"refused by the safety screen: the approach breaks .*joint 'joint_6'"):
        screen_motion(tx40, limits, fast, what="the approach")
    far = approach(list(tx40.joints), q0, np.array([0.0, 2.5, 0.0, 0.0, 0.0, 0.0]), 5.0)  # beyond joint_2's 125°
    with pytest.raises(FrictionIdError, match="joint 'joint_2' position"):
        screen_motion(tx40, limits, far)
    with pytest.raises(FrictionIdError, match="are not tx40's"):
        screen_motion(tx40, limits, Motion(["a"], [0.0], [[0.0]], [[0.0]], [[0.0]]))
