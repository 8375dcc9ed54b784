#!/usr/bin/env python
"""How well can any ~20 s recording determine the TX40 Stribeck shapes? A Cramér–Rao bound.

    .venv/bin/python bench/tx40_stribeck_information.py [--duration 20] [--rate 1000]

For each joint of ``bags/tx40_truth.json`` (docs/reference.md#tx40 friction, torque noise σ 0.05 N·m) the
joint's friction torque alone, τ = Fv q̇ + sign(q̇)(Fc + (Fs − Fc) exp(−|q̇/vs|^δ)), is taken as
the measurement: every other term (inertia, gravity, the other joints) known exactly, the
velocity noise-free, the noise white at ``--rate`` — an optimistic setting, so the σ printed
is a lower bound for the real problem. It prints σ of vs and δ (as % of the truth)

* on the joint's velocity profile in the bundled excitation bag (``bags/tx40_excitation``),
  and on its Fourier part alone (the first ``fourier_duration`` s, no plateaus),
* for the best possible recording of ``--duration`` s: the c-optimal design for δ, i.e. the
  distribution of constant velocities (|q̇| from 1e-3 to the joint's limit) that minimises
  var(δ), found with Torsney's multiplicative algorithm.

A parameter can be placed within 5 % with 95 % confidence only if 1.96 σ < 5 %, so when even
the c-optimal σ(δ) exceeds 2.55 % no recording of that length and noise resolves δ to 5 %.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from frictionid_core.excitation.design import trajectory_from_dict
from frictionid_core.friction import get_model
from frictionid_core.robots import build_tx40
from frictionid_core.synthetic.robot_logs import truth_friction

ROOT = Path(__file__).resolve().parents[1]
NAMES = ("Fv", "Fc", "Fs", "vs", "delta")


def regressors(theta: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N, 5) derivatives of the Stribeck torque in (Fv, Fc, Fs, vs, δ) at velocities v."""
    model = get_model("stribeck")
    order = [model.names.index(n) for n in NAMES]
    p = np.zeros(len(model.names))
    p[order] = theta
    cols = []
    for i in order:
        h = 1e-6 * abs(p[i])
        up, down = p.copy(), p.copy()
        up[i] += h
        down[i] -= h
        cols.append((model.torque(up, v) - model.torque(down, v)) / (2.0 * h))
    return np.stack(cols, axis=1)


def c_optimal(m: np.ndarray, c: np.ndarray, iterations: int = 20000) -> tuple[np.ndarray, float]:
    """Torsney's algorithm: weights w on the rows of m (n, k) minimising cᵀ M(w)⁻¹ c; returns (w, value)."""
    w = np.full(len(m), 1.0 / len(m))
    for _ in range(iterations):
        u = np.linalg.solve((m * w[:, None]).T @ m, c)
        g = np.abs(m @ u)
        w *= g / (w @ g)
    info = (m * w[:, None]).T @ m
    return w, float(c @ np.linalg.solve(info, c))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=20.0, help="recording length (s)")
    ap.add_argument("--rate", type=float, default=1000.0, help="sampling rate (Hz)")
    a = ap.parse_args(argv)
    truth = json.loads((ROOT / "bags" / "tx40_truth.json").read_text())["bags"]["tx40_excitation"]
    traj = trajectory_from_dict(truth["trajectory"])
    _, qd, _ = traj.evaluate(np.arange(0.0, traj.duration, 1.0 / truth["rate_hz"]))
    n_fourier = int(round(getattr(traj, "fourier", traj).duration * truth["rate_hz"]))
    noise = truth["noise"]["torque"]
    n = a.duration * a.rate
    robot = build_tx40()
    vmax = dict(zip(robot.joints, robot.velocity_limit))  # docs/reference.md#tx40, rad/s
    print(f"Stribeck shapes, friction-only Cramér–Rao bound (torque noise {noise} N·m, {a.rate:g} Hz)")
    print(f"{'joint':8} {'Fs-Fc N·m':>9} {'vs':>6} {'δ':>5} | bag ({traj.duration:g} s) "
          f"{'σ vs %':>7} {'σ δ %':>7} "
          f"| its Fourier part {'σ δ %':>7} | c-optimal ({a.duration:g} s) {'σ δ %':>7} {'1.96σ δ %':>9}")
    _, _, friction_params = truth_friction(truth)
    for j, joint in enumerate(truth["joints"]):
        f = friction_params[joint]
        theta = np.array([f["Fv"], f["Fc"], f["Fs"], f["vs"], f["delta"]])
        sd_bag, sd_fourier = (100.0 * noise * np.sqrt(np.diag(np.linalg.inv(m.T @ m))) / np.abs(theta)
                              for m in (regressors(theta, qd[:, j]), regressors(theta, qd[:n_fourier, j])))
        grid = np.geomspace(1e-3, vmax[joint], 600)
        c = np.eye(5)[4]
        _, value = c_optimal(regressors(theta, grid), c)
        sd_opt = 100.0 * noise * np.sqrt(value / n) / theta[4]
        print(f"{joint:8} {theta[2] - theta[1]:9.3f} {theta[3]:6.3f} {theta[4]:5.2f} | {'':11}{sd_bag[3]:7.2f} "
              f"{sd_bag[4]:7.2f} | {'':16}{sd_fourier[4]:7.2f} | {'':17}{sd_opt:7.2f} {1.96 * sd_opt:9.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
