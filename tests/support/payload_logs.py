"""Synthetic logs of a robot without and with a known payload (TX40, UR5 of example-robot-data).

Each log: a Fourier excitation within the joint limits (its own seed), Coulomb friction of known
levels, white torque noise 0.05 N·m, 1 kHz (:func:`frictionid_core.synthetic.robot_logs.synthesize`); the
loaded logs come from the robot model with the payload fixed to its last link
(:func:`frictionid_core.robots.payload_model.robot_with_payload`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from frictionid_core.robots import Payload

# A 2.8 kg tool 7 cm out along the flange axis, a little off it; inertia of a ~10 cm body.
PAYLOAD = dict(mass=2.8, com=(0.02, -0.03, 0.07),
               inertia=((0.012, 0.001, 0.0), (0.001, 0.010, 0.0005), (0.0, 0.0005, 0.008)))


@dataclass(frozen=True)
class LoadedLogs:
    """A robot's system name, model, payload truth and logs: ``base`` (without the payload),
    ``loaded`` and ``validation`` (with it, other excitations and noise)."""

    system: str
    robot: object
    payload: Payload
    base: object
    loaded: object
    validation: object
    friction: dict


def robot_of(name: str):
    """(system name, RobotModel) of ``tx40`` or ``ur5``."""
    from frictionid_core.robots import example_robot_data_dir, load_urdf

    if name == "tx40":
        from frictionid_core.robots import build_tx40

        return "tx40", build_tx40()
    path = example_robot_data_dir() / "ur_description" / "urdf" / "ur5_robot.urdf"
    return f"urdf:{path}", load_urdf(path)


def excitation(robot, seed: int, duration: float = 10.0, scale: float = 1.0):
    """A 4-harmonic Fourier trajectory of every joint within the limits (``scale`` < 1: slower)."""
    from frictionid_core.excitation.design import FourierTrajectory, fit_to_limits

    rng = np.random.default_rng(seed)
    traj = FourierTrajectory(list(robot.joints), np.zeros(robot.nv), rng.uniform(-1, 1, (robot.nv, 4)),
                             rng.uniform(-1, 1, (robot.nv, 4)), 2 * np.pi / duration, duration)
    traj = fit_to_limits(robot, traj)
    return traj if scale == 1.0 else type(traj)(traj.joints, traj.q0, scale * traj.a, scale * traj.b, traj.wf,
                                                traj.duration)


def coulomb_friction(robot, factor: float = 1.0) -> dict[str, dict[str, float]]:
    """Known Coulomb friction per joint (``factor`` × the levels): the TX40's published levels, a
    UR5's of the same order (within the safety screen's limits of both)."""
    if robot.name == "tx40":
        from frictionid_core.robots import tx40

        levels = tx40.published_friction("coulomb", False)
        return {j: {n: factor * v for n, v in levels[j].items()} for j in robot.joints}
    return {j: {"Fv": factor * (2.0 + k), "Fc": factor * (3.0 + 0.5 * k)} for k, j in enumerate(robot.joints)}


@cache
def loaded_logs(name: str, friction_factor: float = 1.0) -> LoadedLogs:
    """The three logs of ``name`` (``tx40`` or ``ur5``); the loaded ones with ``friction_factor``
    × the base log's friction levels (friction rising with the load)."""
    from frictionid_core.robots import default_link, robot_with_payload
    from frictionid_core.synthetic import synthesize

    system, robot = robot_of(name)
    payload = Payload(default_link(robot), **PAYLOAD)
    heavy = robot_with_payload(robot, payload)
    unloaded, loaded = coulomb_friction(robot), coulomb_friction(robot, friction_factor)
    base, _ = synthesize(robot, excitation(robot, 1), friction="coulomb", friction_params=unloaded, seed=3)
    run, _ = synthesize(heavy, excitation(robot, 2), friction="coulomb", friction_params=loaded, seed=4)
    validation, _ = synthesize(heavy, excitation(robot, 5), friction="coulomb", friction_params=loaded, seed=6)
    return LoadedLogs(system, robot, payload, base, run, validation, loaded)
