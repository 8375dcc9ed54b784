"""What the identification worker runs for ``~/run_experiment`` (no ROS import): the CPU-heavy parts,
kept off the node's input thread like every identification (:mod:`frictionid_ros.worker`).

* :class:`PlanTask`: the excitation (designed within the robot's limits as ``frictionid excite`` does,
  written to the experiment's folder, or read from a file), its points, the approach from the robot's
  pose to its start, and both screened against the robot's limits
  (:func:`frictionid_core.safety.screen_motion`) before anything is commanded;
* :class:`FitTask`: the recorded bag loaded as ``frictionid identify`` loads it, identified on its first
  part and validated on the rest (:func:`frictionid_core.experiment.fit_and_validate`).

Each ``run(series)`` (``series`` unused: the task reads its own data) returns an outcome whose
``parameters()`` the worker checks are finite.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from frictionid_ros.experiment.settings import Design


@dataclass
class Plan:
    """The screened motion of an experiment: ``approach`` and ``excitation`` (Motions, the robot's
    joint order), the excitation's file and report (``frictionid excite --json``'s keys), the screen's
    reports."""

    approach: object
    excitation: object
    excitation_file: str
    report: dict
    screened: dict

    def parameters(self) -> dict:
        return {}


@dataclass(frozen=True)
class PlanTask:
    """The plan of an experiment of ``system`` (a robot system's name): the excitation of
    ``excitation_file`` (a path; empty: designed with ``design`` and written to ``out``) as points at
    ``rate_hz``, the approach from ``q_now`` at ``approach_speed`` × the limits."""

    system: str
    excitation_file: str
    design: Design
    out: str
    q_now: tuple[float, ...]
    approach_speed: float
    rate_hz: float

    def run(self, series=None) -> Plan:
        from frictionid_core.excitation import load_collision_model, load_trajectory, robot_limits, robot_of
        from frictionid_core.experiment import approach, approach_duration, sampled
        from frictionid_core.safety import screen_motion
        from frictionid_core.systems import get_system

        d = self.design
        system = get_system(self.system)
        robot, _ = robot_of(system, self.system)
        limits = robot_limits(robot, d.margin, d.max_acceleration)
        collision = None
        if d.collision:
            collision = load_collision_model(robot, self.system[len("urdf:"):] if self.system.startswith("urdf:")
                                             else "", d.clearance_m, d.floor_z)
        if self.excitation_file:
            trajectory = load_trajectory(self.excitation_file)
            path, report = self.excitation_file, {"file": self.excitation_file}
        else:
            trajectory, report = self._design(system, robot, limits, collision)
            path = str(Path(self.out) / "excitation.npz")
            trajectory.save(Path(path))
        excitation = sampled(trajectory, list(robot.joints), self.rate_hz)
        screened = {"excitation": screen_motion(robot, limits, excitation, collision, "the excitation")}
        q_now = np.array(self.q_now, dtype=float)
        seconds = approach_duration(q_now, excitation.start, limits.velocity, limits.acceleration, self.approach_speed)
        move = approach(list(robot.joints), q_now, excitation.start, seconds, self.rate_hz)
        screened["approach"] = screen_motion(robot, limits, move, collision, "the approach to the start pose")
        for r in screened.values():
            r.pop("violations", None)
        return Plan(move, excitation, path, report, screened)

    def _design(self, system, robot, limits, collision):
        from frictionid_core.excitation import design_excitation

        d, t0 = self.design, time.perf_counter()
        design = design_excitation(system, robot, limits=limits, harmonics=d.harmonics, period=d.period_s,
                                   duration=d.duration_s, evals=d.evals, seed=d.seed, collision=collision)
        report = dict(design.to_dict(), system=self.system, trajectory=design.trajectory.to_dict(),
                      wall_time_s=time.perf_counter() - t0)
        if collision is not None:
            report["collision"] = {"clearance_m": collision.clearance, "floor_z": collision.floor,
                                   "pairs": collision.pairs, "excluded": collision.excluded}
        return design.trajectory, report


@dataclass
class Fit:
    """The experiment's identification ``result`` (IdentifyResult), its ``validation`` metrics and the
    joints' limits of its data (for the results file)."""

    result: object
    validation: dict
    limits: dict

    def parameters(self) -> dict:
        return dict(self.result.params)


@dataclass(frozen=True)
class FitTask:
    """Identify ``request`` on the bag ``bag`` (its ``topic``) before ``split_s`` [s from its first
    sample], validate after it."""

    bag: str
    topic: str
    request: object
    split_s: float

    def run(self, series=None) -> Fit:
        from frictionid_core import load
        from frictionid_core.experiment import fit_and_validate
        from frictionid_core.safety import data_limits

        data = load(self.bag, topic=self.topic)
        result, validation = fit_and_validate(data, self.request, self.split_s)
        return Fit(result, validation, data_limits(data, None, result.friction_rows()))
