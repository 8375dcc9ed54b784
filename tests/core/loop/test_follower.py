"""The simulated arm's position servo (frictionid_core.loop.TrajectoryFollower): it follows a
trajectory, a stream of positions and a hold, its torque clamped at the effort limits."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.experiment import approach
from frictionid_core.loop import SimArm, TrajectoryFollower, hidden_friction, load_robot


@pytest.fixture(scope="module")
def tx40():
    return load_robot("tx40")


def run(sim, follower, seconds):
    err = []
    for _ in range(int(round(seconds * 1000))):
        sim.step(follower.torque(sim.t, sim.q, sim.qd))
        err.append(follower.reference(sim.t)[0] - sim.q)
    return np.array(err)


def test_it_follows_a_trajectory_despite_the_hidden_friction(tx40):
    q0 = np.array([0.0, 0.3, 1.2, 0.0, 0.5, 0.0])
    sim = SimArm(tx40, hidden_friction("tx40", tx40.joints), q0=q0, guard_reversals=True)
    f = TrajectoryFollower(tx40, q0)
    target = q0 + np.array([0.5, -0.4, 0.3, 0.8, -0.5, 1.0])
    f.follow(approach(list(tx40.joints), q0, target, 1.5), t0=0.1)
    err = run(sim, f, 2.5)
    # the friction steps at start and stop (up to 7.8 N·m) against a 25 Hz servo without integral action: a few
    # mrad at most, also at rest (joint_6: Fc 1.83 N·m / (M·ω²) ≈ 5 mrad)
    assert np.abs(err).max() < 0.01
    np.testing.assert_allclose(sim.q, target, atol=0.01)


def test_a_hold_stops_the_arm_within_its_torque(tx40):
    q0 = np.zeros(6)
    sim = SimArm(tx40, hidden_friction("tx40", tx40.joints), q0=q0, guard_reversals=True)
    sim.data.qvel[:] = [2.0, -2.0, 2.0, 3.0, 3.0, 5.0]  # fast, then told to hold where it is
    f = TrajectoryFollower(tx40, q0)
    f.hold(sim.q)
    taus = []
    for _ in range(500):
        tau = f.torque(sim.t, sim.q, sim.qd)
        taus.append(tau)
        sim.step(tau)
    assert np.all(np.abs(taus) <= f.limit + 1e-12)  # clamped at the drives' limits
    assert np.abs(sim.qd).max() < 0.01  # still within 0.5 s


def test_a_stream_is_played_back_smoothly_from_its_buffer(tx40):
    """Commands every 4 ms of a ramp at 0.5 rad/s, received on time or in pairs every 8 ms (the second of
    a pair one interval early): the playback infers the sender's schedule from the earliest receipts and
    plays command k ten intervals (the buffer) after it — the arm follows the ramp 10 intervals late, or
    9 with the pairs' early commands, within 0.5 mrad; and the servo's
    torque stays smooth: it changes by less than 0.05 N·m from one step to the next (a command taken as
received, without the buffer, jumps by tens of N·m at each uneven arrival)."""
    q0 = np.zeros(6)
    speed, period = 0.5, 0.004
    for pattern, lag in (("even", 10), ("pairs", 9)):
        sim = SimArm(tx40, None, q0=q0)
        f = TrajectoryFollower(tx40, q0, stream_rate_hz=1.0 / period)
        sent, worst, taus = 0, 0.0, []
        for step in range(600):
            now = sim.t
            due = int(now / period) + 1 if pattern == "even" else 2 * (int(now / (2 * period)) + 1)
            while sent < due:  # "pairs": two commands at once every 8 ms
                f.stream(now, np.full(6, speed * sent * period))
                sent += 1
            tau = f.torque(sim.t, sim.q, sim.qd)
            sim.step(tau)
            if step > 300:
                taus.append(tau)
                worst = max(worst, np.abs(speed * (sim.t - lag * period) - sim.q).max())
        assert worst < 5e-4, (pattern, worst)
        jerk = np.abs(np.diff(np.array(taus), axis=0)).max()
        assert jerk < 0.05, (pattern, jerk)


def test_without_the_guard_a_stribeck_hump_chatters_under_the_servo(tx40):
    """Why the arm of frictionid experiment guards reversals (frictionid_core.loop.sim): joint_5's hump
    (Fs = 1.2 Fc) held by the servo flips its velocity every step, ±0.05 rad/s for ever, without it."""
    q0 = np.zeros(6)
    speeds = []
    for guard in (False, True):
        sim = SimArm(tx40, hidden_friction("tx40", tx40.joints), q0=q0, guard_reversals=guard)
        sim.data.qvel[:] = [2.0, -2.0, 2.0, 3.0, 3.0, 5.0]
        f = TrajectoryFollower(tx40, q0)
        f.hold(sim.q)
        run(sim, f, 1.0)
        speeds.append(abs(sim.qd[4]))
    assert speeds[0] > 0.04 and speeds[1] < 0.005, speeds


def test_a_stream_that_runs_dry_goes_on_then_holds(tx40):
    f = TrajectoryFollower(tx40, np.zeros(6), stream_rate_hz=250.0)
    for k in range(10):
        f.stream(0.004 * k, np.full(6, 0.001 * k))  # 0.25 rad/s
    h, start = 0.004, 0.04  # played from the first receipt + 10 intervals
    q, v, _ = f.reference(start + 9 * h + 0.05)  # 50 ms past the last command: on along 0.25 rad/s
    np.testing.assert_allclose(v, 0.25)
    np.testing.assert_allclose(q, 0.009 + 0.25 * 0.05)
    for t in (start + 9 * h + 0.2, start + 100.0):  # past MAX_STREAM_GAP_S: the last command, at rest
        q, v, _ = f.reference(t)
        np.testing.assert_allclose(q, 0.009) and np.testing.assert_allclose(v, 0.0)
