"""The tracking task and controller of the loop (no ROS import).

Trajectory: per joint q_d = q0 + A·(1 − cos 2πf·t) — a low-speed motion with a reversal every
half period, peak speed 2πf·A, zero speed at t = 0. Controller (what a JointGroupEffortController
user writes): τ = rnea(q_d, q̇_d, q̈_d) (Pinocchio rigid-body feed-forward) + Kp·(q_d − q) +
Kd·(q̇_d − q̇) + τ_friction, the last one from frictionid's feed-forward when enabled. Gains come
from a bandwidth on the diagonal of the mass matrix at q0: Kp = m·ω², Kd = 2ζ·m·ω.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.friction import smooth_sign

PEAK_SPEED = 0.25  # peak joint speed of the default task [rad/s | m/s]
FREQUENCIES = (0.20, 0.17, 0.23, 0.19, 0.25, 0.21)  # reversal frequencies of the default task [Hz]
BANDWIDTH_HZ = 8.0  # PD bandwidth [Hz]
DAMPING = 0.9  # PD damping ratio


@dataclass(frozen=True)
class Trajectory:
    """q_d = q0 + A·(1 − cos 2πf·t) per joint: q0, A (J,) [rad | m], f (J,) [Hz]."""

    q0: np.ndarray
    amplitude: np.ndarray
    frequency: np.ndarray

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_d, q̇_d, q̈_d) at time t [s] since the start of the task."""
        w = 2.0 * np.pi * self.frequency
        c, s = np.cos(w * t), np.sin(w * t)
        return self.q0 + self.amplitude * (1.0 - c), self.amplitude * w * s, self.amplitude * w * w * c


def default_trajectory(robot, speed: float = PEAK_SPEED) -> Trajectory:
    """The low-speed task of ``robot``: every joint moves at peak ``speed`` from the middle of its
    limits (0 when unlimited; the TX40 from an elbow-up posture) within a quarter of its range."""
    nv = robot.nv
    if robot.name == "tx40":
        q0 = np.array([0.0, 0.3, 1.2, 0.0, 0.5, 0.0])
    else:
        lo, hi = robot.lower, robot.upper
        q0 = np.where(np.isfinite(lo) & np.isfinite(hi), 0.5 * (lo + hi), 0.0)
    f = np.resize(np.array(FREQUENCIES), nv)
    amp = speed / (2.0 * np.pi * f)
    span = np.where(np.isfinite(robot.upper - robot.lower), robot.upper - robot.lower, np.inf)
    amp = np.minimum(amp, 0.125 * span)  # q0 + 2A stays within a quarter of the range above the middle
    return Trajectory(q0 - amp, amp, f)


class Controller:
    """PD + Pinocchio rigid-body feed-forward of ``robot``; ``kp``, ``kd`` (J,) or from
    :data:`BANDWIDTH_HZ` at the trajectory's start."""

    def __init__(self, robot, trajectory: Trajectory, kp=None, kd=None):
        import pinocchio

        self._pin = pinocchio
        self.robot = robot
        self.trajectory = trajectory
        m = np.diag(robot.mass_matrix(trajectory.q0))
        w = 2.0 * np.pi * BANDWIDTH_HZ
        self.kp = np.asarray(m * w * w if kp is None else kp, dtype=float)
        self.kd = np.asarray(2.0 * DAMPING * m * w if kd is None else kd, dtype=float)
        self._data = robot.model.createData()

    def command(self, t: float, q: np.ndarray, qd: np.ndarray, tau_friction=None):
        """(τ (J,), q_d, q̇_d) at task time t [s] from the measured q, q̇; ``tau_friction`` (J,) is added."""
        qd_d = self.trajectory.at(t)
        q_d, v_d, a_d = qd_d
        tau = np.array(self._pin.rnea(self.robot.model, self._data, self.robot.configuration(q_d), v_d, a_d))
        tau += self.kp * (q_d - q) + self.kd * (v_d - qd)
        if tau_friction is not None:
            tau += tau_friction
        return tau, q_d, v_d


def friction_feedforward(model, params: np.ndarray, v: np.ndarray, eps: float) -> np.ndarray:
    """Friction feed-forward (J,) of per-joint parameters ``params`` (J, k) of ``model`` at the
    desired velocities v (J,), sign smoothed by tanh(v/eps) (:func:`smooth_sign`)."""
    return model.torque_each(params, np.asarray(v, dtype=float), eps)


def run_loop(sim, controller: Controller, seconds: float, feedforward=None) -> np.ndarray:
    """Run ``controller`` on ``sim`` in-process for ``seconds`` [s]; ``feedforward(v_d)`` → (J,)
    friction torque (None: off). Returns the tracking error q_d − q (N, J) [rad | m] per step."""
    n = int(round(seconds / sim.model.opt.timestep))
    t0 = sim.t
    err = np.empty((n, controller.robot.nv))
    for k in range(n):
        t = sim.t - t0
        q_d, v_d, _ = controller.trajectory.at(t)
        ff = feedforward(v_d) if feedforward is not None else None
        tau, q_d, _ = controller.command(t, sim.q, sim.qd, ff)
        sim.step(tau)
        err[k] = controller.trajectory.at(sim.t - t0)[0] - sim.q
    return err


__all__ = ["Controller", "Trajectory", "default_trajectory", "friction_feedforward", "run_loop", "smooth_sign"]
