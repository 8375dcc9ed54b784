"""Nonlinear laws reach the noise floor (issue 38, item 1), on truths made independently of the code
under test (tests/support/friction_truths.py: analytic motion, the generator's own RK4 for the
element states, its own Stribeck law; checked here against scipy's Radau).

* LuGre joints with pre-sliding content (reversals, dwells, 0.1–3 mrad back-and-forth, plateaus over
  the Stribeck range), 0.5 % torque noise, 1 µrad position noise, identified with the CLI's
  defaults (``ls``: the static part by lm, then every parameter by lm), validated on another motion
  and noise draw: the acceptance is Fc, Fs within 3 %, vs 10 %, σ0 15 %, σ1 30 % and the validation's
  RMSE on every row within 1.3 × the torque noise σ. Measured (bench/dynamic_laws.py, 11 random
  truths, seeds printed there): parameters within 0.5 % but for J, Fv and σ1 at 50 Hz; the issue's
  truth at 1 kHz: every parameter within 0.2 %, 1.02 σ.
* TX40 joint-2-like logs (500 Hz, stamps jittered by ±20 %, δ = 1.7, the TX40's small dip Fs − Fc =
  0.14 N·m) with ``--solver de``: δ was 2.49; measured now over seeds 0–3: 1.60, 1.72, 1.87, 1.65,
  σ 0.09–0.11 (every solver alike), within the 15 % of the acceptance.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import frictionid_core as fid
from frictionid_core.identification import SolverOptions
from support.friction_truths import (
    Motion,
    Segment,
    dynamic_friction,
    dynamic_log,
    micro_motion,
    plateau,
    tx40_j2_like_log,
    windowed_sine,
)

ISSUE_LUGRE = {"Fv": 2.5, "Fc": 6.0, "Fs": 8.5, "vs": 0.05, "sigma0": 2e4, "sigma1": 150.0}  # J 0.8
LIMITS = {"Fc": 3.0, "Fs": 3.0, "vs": 10.0, "sigma0": 15.0, "sigma1": 30.0}


def test_the_generator_follows_a_radau_integration():
    """The generator's RK4 (200 steps a sample at 1 kHz) against Radau at rtol 1e-10 along a
    micro-motion, a reversal and a plateau: measured 1.7e-9 N·m; the bound 1e-7 of Fs."""
    p = ISSUE_LUGRE
    motion = Motion((Segment("rest", 0.1), micro_motion(3e-4, 2, 4.0), Segment("rest", 0.1),
                     windowed_sine(0.3, 2, 2.0), plateau(-0.1, 0.2, 0.15)))
    t = np.arange(0.0, motion.duration, 1e-3)
    mine = dynamic_friction("lugre", p, motion, t, substeps=200)

    grid = np.arange(0.0, motion.duration, 1e-6)  # the velocity for the solver: the motion's, 1 µs apart
    speed = motion.evaluate(grid)[1]

    def level(v):
        return p["Fc"] + (p["Fs"] - p["Fc"]) * np.exp(-((v / p["vs"]) ** 2))

    def rate(time, z):
        v = float(np.interp(time, grid, speed))
        return [v - abs(v) * z[0] * p["sigma0"] / level(v)]

    def jac(time, z):
        v = float(np.interp(time, grid, speed))
        return [[-abs(v) * p["sigma0"] / level(v)]]

    sol = solve_ivp(rate, (0.0, t[-1]), [0.0], method="Radau", jac=jac, rtol=1e-10, atol=1e-15, max_step=5e-3,
                    t_eval=t)
    _, v, _ = motion.evaluate(t)
    z = sol.y[0]
    reference = p["Fv"] * v + p["sigma0"] * z + p["sigma1"] * (v - np.abs(v) * z * p["sigma0"] / level(v))
    assert np.abs(mine - reference).max() < 1e-7 * p["Fs"]


def errors(params: dict, truth: dict) -> dict:
    return {k: 100.0 * (params[k] / truth[k] - 1.0) for k in LIMITS}


@pytest.mark.slow
def test_a_lugre_joint_at_200_hz_reaches_the_noise_floor():
    """Measured over seeds 3, 5, 7: Fc, Fs within 0.2 %, vs 0.4 %, σ0 0.4 %, σ1 1.5 %; validation
    1.07–1.10 σ on every row (the bounds: the acceptance)."""
    truth = {"Fv": 1.5, "Fc": 4.0, "Fs": 6.0, "vs": 0.03, "sigma0": 2e4, "sigma1": 60.0}
    est, known = dynamic_log("lugre", truth, seed=3, rate=200.0, inertia=0.3)
    val, _ = dynamic_log("lugre", truth, seed=4, rate=200.0, inertia=0.3)
    fit = fid.identify(est, fid.IdentifyRequest(system="joint", friction="lugre"))
    err = errors(fit.params, truth)
    assert all(abs(err[k]) < LIMITS[k] for k in LIMITS), err
    metrics = fid.validate(val, fit)
    assert metrics["all_rows"]["rmse"] < 1.3 * known["torque_noise"]
    assert metrics["all_rows"]["samples"] > metrics["samples"]


@pytest.mark.slow
def test_a_lugre_joint_leaving_rest_at_the_trim_reaches_the_noise_floor():
    """bench/dynamic_laws.py's seed 2265 (motion seeds 37945, 7978; 200 Hz): the trim (0.575 s) ends as
    the joint leaves rest, where the states' sliding start is wrong for 0.2 s. That bent J and the dip
    (J −0.78 %, vs +4.4 %; validation 1.65 σ against the truth's 1.18 σ). With the rows before each
    first reversal left out of cost and metrics: every parameter within 0.2 %, validation 1.05 σ."""
    truth = {"Fv": 0.70911, "Fc": 1.22979, "Fs": 1.71183, "vs": 0.0198596, "sigma0": 2113.33, "sigma1": 54.0449}
    est, known = dynamic_log("lugre", truth, seed=37945, rate=200.0, inertia=0.57213, top_speed=0.41819)
    val, _ = dynamic_log("lugre", truth, seed=7978, rate=200.0, inertia=0.57213, top_speed=0.41819)
    fit = fid.identify(est, fid.IdentifyRequest(system="joint", friction="lugre"))
    err = errors(fit.params, truth)
    assert all(abs(err[k]) < LIMITS[k] for k in LIMITS), err
    assert fit.params["J"] == pytest.approx(0.57213, rel=0.005)
    metrics = fid.validate(val, fit)
    assert metrics["all_rows"]["rmse"] < 1.3 * known["torque_noise"]


@pytest.mark.slow
def test_the_issue_lugre_joint_at_1_khz_reaches_the_noise_floor():
    """The issue's truth (J 0.8, Fc 6, Fs 8.5, vs 0.05, Fv 2.5, σ0 2e4, σ1 150; 0.5 % noise): it
    fitted at 5.1 % (moving rows) and 12.7 % (every row) against a 0.50 % floor. Measured now:
    every parameter within 0.2 %, validation 1.02 σ on every row."""
    est, known = dynamic_log("lugre", ISSUE_LUGRE, seed=0, rate=1000.0, inertia=0.8)
    val, _ = dynamic_log("lugre", ISSUE_LUGRE, seed=1, rate=1000.0, inertia=0.8)
    fit = fid.identify(est, fid.IdentifyRequest(system="joint", friction="lugre", solver="hybrid"))
    err = errors(fit.params, ISSUE_LUGRE)
    assert all(abs(err[k]) < LIMITS[k] for k in LIMITS), err
    assert fit.params["J"] == pytest.approx(0.8, rel=0.03)
    metrics = fid.validate(val, fit)
    assert metrics["all_rows"]["rmse"] < 1.3 * known["torque_noise"]


@pytest.mark.slow
def test_stribeck_delta_of_a_jittered_tx40_joint_2_log_with_de():
    """``--solver de`` with its defaults on the issue's log shape: δ within 15 % of 1.7, or not
    determined (σ ≥ 15 %) with the truth within 1.96 σ."""
    log, truth = tx40_j2_like_log(1.7, seed=0)
    fit = fid.identify(log, fid.IdentifyRequest(system="tx40-j2", friction="stribeck", solver=SolverOptions("de")))
    delta, sd = fit.params["delta"], fit.std["delta"]
    assert abs(delta / 1.7 - 1.0) < 0.15 or (sd >= 0.15 * delta and abs(delta - 1.7) < 1.96 * sd), (delta, sd)
    assert fit.varpro  # the shape searched, the rest in closed form
    assert fit.preprocessing["resampled_reversal_rows"]["joint_2"] > 0


def test_rows_a_resampling_smeared_across_a_reversal_are_left_out():
    """A log with jittered stamps is resampled; its rows within one stamp interval of a reversal
    (their effort interpolated across the friction's step) are left out; a regular log keeps them."""
    jittered, _ = tx40_j2_like_log(1.7, seed=0, seconds=8.0)
    regular, _ = tx40_j2_like_log(1.7, seed=0, seconds=8.0, jitter=0.0)
    request = fid.IdentifyRequest(system="tx40-j2", friction="stribeck", fixed={"vs": 0.05, "delta": 1.7},
                                  preprocessing={"decimate": 1})
    smeared = fid.identify(jittered, request).preprocessing
    assert smeared["resampled_reversal_rows"]["joint_2"] > 0
    assert smeared["resampled_interval_s"] == pytest.approx(1.0 / 500 * 1.4, rel=0.1)
    assert fid.identify(regular, request).preprocessing["resampled_reversal_rows"]["joint_2"] == 0


def test_variable_projection_is_the_default_for_a_law_with_a_dip():
    assert SolverOptions("de").resolved(False, "stribeck").varpro
    assert not SolverOptions("de").resolved(False, "coulomb").varpro
    assert not SolverOptions("de", warm_start=False).resolved(False, "stribeck").varpro  # the thesis protocol
    assert SolverOptions("de", warm_start=False).resolved(True, "stribeck").varpro  # a robot: always
    assert not SolverOptions("de", varpro=False).resolved(True, "stribeck").varpro  # asked for
