"""Synthetic logs of a 6-DOF arm (the UR5 of example-robot-data) and of one gravity-loaded joint
(:func:`pendulum`) for the checks of what a fit takes from each joint: efforts logged against the
joint axis, joints that only tremble, small efforts.

Each log: Coulomb friction of known levels (:data:`FRICTION`, a few N·m, under the arm's gravity
load of up to ~50 N·m), 500 Hz, position noise 1e-6 rad, and white torque noise of ``noise`` × each
joint's own RMS torque (every joint as clean as the others, whatever its size)
(:func:`frictionid_core.synthetic.synthesize`).
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np

from frictionid_core.timeseries import JointSeries


def friction(robot, scale: float = 1.0) -> dict[str, dict[str, float]]:
    """Coulomb friction per joint: Fv 0.8 … 1.8, Fc 1.5 … 3.0 (× ``scale``)."""
    return {j: {"Fv": scale * (0.8 + 0.2 * k), "Fc": scale * (1.5 + 0.3 * k)} for k, j in enumerate(robot.joints)}


@cache
def ur5():
    """(system name, RobotModel) of the UR5."""
    from support.payload_logs import robot_of

    return robot_of("ur5")


def with_noise(series: JointSeries, noise: float, seed: int) -> JointSeries:
    """``series`` with white torque noise of ``noise`` × each joint's RMS torque."""
    rms = np.sqrt(np.mean(series.effort**2, axis=0))
    rng = np.random.default_rng(seed + 100)
    return replace(series, effort=series.effort + rng.normal(0.0, 1.0, series.effort.shape) * noise * rms)


def arm_log(seed: int, noise: float = 0.01, *, friction_params: dict | None = None, trajectory=None,
            source: str = "ur5") -> JointSeries:
    """A 10 s UR5 log of a 4-harmonic Fourier excitation of every joint (seed ``seed``)."""
    from frictionid_core.synthetic import synthesize
    from support.payload_logs import excitation

    _, robot = ur5()
    series, _ = synthesize(robot, trajectory or excitation(robot, seed), friction="coulomb",
                           friction_params=friction_params or friction(robot), torque_noise=0.0, seed=seed, rate=500.0,
                           source=source)
    return with_noise(series, noise, seed)


def sweep(joint: str, seed: int, noise: float = 0.01, *, still: float = 0.3, tremble: float = 0.0) -> JointSeries:
    """A 10 s UR5 log in which ``joint`` alone moves (3 harmonics), the others still at ``still`` rad
    or, with ``tremble`` > 0, trembling ±``tremble`` rad around it (0.6 Hz) the way a joint held by a
    stiff controller does: its friction stuck, a pre-sliding spring reaching ±Fc at ±``tremble``
    instead of a Coulomb level."""
    from frictionid_core.excitation.design import FourierTrajectory, fit_to_limits

    _, robot = ur5()
    rng = np.random.default_rng(seed)
    a, b = np.zeros((robot.nv, 3)), np.zeros((robot.nv, 3))
    k = robot.joints.index(joint)
    a[k], b[k] = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
    traj = fit_to_limits(robot, FourierTrajectory(list(robot.joints), np.full(robot.nv, still), a, b, 2 * np.pi / 5,
                                                  10.0), 0.1)
    if not tremble:
        return arm_log(seed, noise, trajectory=traj, source=f"sweep_{joint}")
    others = [i for i, j in enumerate(robot.joints) if j != joint]
    a = traj.a.copy()
    a[others, 2] = tremble * 3 * traj.wf  # q = q0 + Σ a_l/(l·wf)·sin(l·wf·t) − …: ±tremble at the 3rd harmonic
    truth = friction(robot)
    stuck = {j: ({"Fv": 0.0, "Fc": 0.0} if i in others else truth[j]) for i, j in enumerate(robot.joints)}
    series = arm_log(seed, 0.0, friction_params=stuck, trajectory=replace(traj, a=a), source=f"sweep_{joint}")
    effort = series.effort.copy()
    for i in others:
        fc, q = truth[robot.joints[i]]["Fc"], series.position[:, i]
        effort[:, i] += np.clip(fc / tremble * (q - np.median(q)), -fc, fc)
    return with_noise(replace(series, effort=effort), noise, seed)


def negated(series: JointSeries, joints: list[str]) -> JointSeries:
    """``series`` with the efforts of ``joints`` negated (a driver's sign opposite to the URDF axis)."""
    effort = series.effort.copy()
    for j in joints:
        effort[:, series.joints.index(j)] *= -1.0
    return replace(series, effort=effort)


def negated_joints(result) -> list[str]:
    """The joints whose efforts a result's drive negates (``effort_scale`` < 0)."""
    drive = result.drive if hasattr(result, "drive") else result.get("drive")
    if not drive:
        return []
    return [j for j, s in zip(drive["joints"], drive["effort_scale"]) if s < 0]


def pendulum(seconds=20.0, phase=0.4, seed=0, source="pendulum") -> JointSeries:
    """One gravity-loaded joint: τ = J·q̈ + Fv·q̇ + Fc·sign(q̇) + m·g·l·sin(q + φ) + offset at 1 kHz
    (J 0.05, Fv 0.7, Fc 0.4, m·g·l 3 N·m, φ 0.5, offset 0.1, noise 0.01 N·m),
    q = 0.8·sin(2π·0.3 t) + 0.3·sin(2.3·2π·0.3 t + phase)."""
    from frictionid_core.friction import FrictionModel

    t = np.arange(int(seconds * 1000)) * 1e-3
    w = 2 * np.pi * 0.3
    q = 0.8 * np.sin(w * t) + 0.3 * np.sin(2.3 * w * t + phase)
    qd = 0.8 * w * np.cos(w * t) + 0.3 * 2.3 * w * np.cos(2.3 * w * t + phase)
    qdd = -0.8 * w**2 * np.sin(w * t) - 0.3 * (2.3 * w) ** 2 * np.sin(2.3 * w * t + phase)
    coulomb = FrictionModel("coulomb").torque([0.7, 0.4], qd)
    tau = 0.05 * qdd + coulomb + 3.0 * np.sin(q + 0.5) + 0.1
    noise = np.random.default_rng(seed).normal(0.0, 0.01, t.size)
    return JointSeries(t, ["j"], q[:, None], (tau + noise)[:, None], source=source)
