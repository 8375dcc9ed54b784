"""The bundled TX40 bags (tools/make_tx40_bags.py): thesis joint-2 identification, full-robot
base parameters, consistency, noise floors and the rank test on real files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from frictionid_core.compare import compare, noise_floor
from frictionid_core.identification import IdentifyRequest, PreprocessingOverrides, SolverOptions, build_model, identify
from frictionid_core.io import load
from frictionid_core.preprocess import Preprocessing
from frictionid_core.synthetic.robot_logs import expected_parameters, truth_friction
from support.data import BAGS

TRUTH = json.loads((BAGS / "tx40_truth.json").read_text())["bags"]


@pytest.fixture(scope="module")
def j2_bags():
    return (load(BAGS / "tx40_j2_excitation", joints=["joint_2"]),
            load(BAGS / "tx40_j2_validation", joints=["joint_2"]))


def test_bags_are_small_and_described():
    for name in ("tx40_excitation", "tx40_validation", "tx40_j2_excitation", "tx40_j2_validation"):
        size = sum(f.stat().st_size for f in (BAGS / name).iterdir())
        assert size < 3e6, name
        assert truth_friction(TRUTH[name])[:2] == ("stribeck", False)
    assert TRUTH["tx40_j2_excitation"]["moving_joints"] == ["joint_2"]
    assert len(TRUTH["tx40_excitation"]["moving_joints"]) == 6


def test_thesis_joint2_model_recovers_the_truth(j2_bags):
    """DE 50 × 100 with variable projection: ZZ, MX, Fv, Fc, Fs within 2 %, vs and δ within 10 % or
    not determined (the calibrated σ ≥ 15 %, the truth within 1.96 σ: issue 38's criterion),
    validation OSA error within 1.1 × the noise floor. The rule's 55.6 Hz (decimation 18, for the
    0.55 Hz motion) cannot follow the Stribeck dip crossed at 4.8 rad/s² (δ +74 %): the fit's vs asks
    for 500 Hz, and the identification refits there. The folds choose 21.5 Hz (0.19 % against the
    rule's 5.5 Hz at 4.2 %) [every parameter but vs, δ within 0.2 %, 1.003 × the floor; vs −5.3 %, δ −17 %
    with a calibrated σ of 25 %: at the floor from 5.5 to 46 Hz, δ moves −17 … +1 % with the cut-off]."""
    est, val = j2_bags
    r = identify(est, IdentifyRequest(system="tx40-j2", friction="stribeck", solver=SolverOptions("de", varpro=True))
                 ).to_dict()
    assert r["preprocessing"]["decimate"] <= 2 and r["preprocessing"]["dip"].startswith("joint_2: its friction dip")
    exp = expected_parameters(TRUTH["tx40_j2_excitation"], "tx40-j2")
    for name, tol in (("ZZ", 0.02), ("MX", 0.02), ("Fv", 0.02), ("Fc", 0.02), ("Fs", 0.02)):
        assert r["params"][name] == pytest.approx(exp[name], rel=tol), name
    for name in ("vs", "delta"):
        value, sigma = r["params"][name], r["std_robust"][name]
        determined = abs(value - exp[name]) <= 0.10 * abs(exp[name])
        undetermined = sigma >= 0.15 * abs(value) and abs(value - exp[name]) <= 1.96 * sigma
        assert determined or undetermined, (name, value, sigma, exp[name])
    floor = noise_floor(val, r, TRUTH["tx40_j2_validation"])
    assert floor["ratio"] < 1.1


def test_hybrid_dip_refit_polishes_and_finds_the_full_search_optimum(j2_bags):
    """After the dip refit hybrid only polishes (lm) the first round's point at the finer rates;
    on the joint-2 bag that reaches the cost of a whole new de + lm search at those rates (to
    1e-6: both end in one least-squares optimum, at ftol 1e-10)."""
    from frictionid_core.identification import solve_model

    est, _ = j2_bags
    hybrid = SolverOptions("hybrid", varpro=True)
    r = identify(est, IdentifyRequest(system="tx40-j2", friction="stribeck", solver=hybrid)).to_dict()
    assert r["preprocessing"]["decimate"] <= 2 and "dip" in r["preprocessing"]
    assert r["optimizer"]["method"] == "hybrid" and "; dip refit at the finer rates: lm from this point [lm:" in \
        r["optimizer"]["message"]
    model = build_model(est, "tx40-j2", "stribeck", False, Preprocessing.from_dict(r["preprocessing"]))
    x, _ = solve_model(model, hybrid)
    full = float(model.batch_cost(x[None])[0])
    assert r["metrics"]["cost"] == pytest.approx(full, rel=1e-6)


def test_a_decimation_too_coarse_for_the_dip_is_a_warning(j2_bags):
    """Decimation 18 set by the user (55.6 Hz) on the joint-2 bag: the fit's vs (≈ 0.05 rad/s, the
    truth; biased a few % at this rate, crossed at 4.81 rad/s²) needs 6 × 4.81/(π·0.05) = 184 Hz of
    anti-alias band, i.e. decimation 2; the decimation the user set is kept (and the 5.5 Hz cut-off the
    folds chose) and the warning says which to use."""
    est, _ = j2_bags
    r = identify(est, IdentifyRequest(system="tx40-j2", friction="stribeck", solver=SolverOptions("lm", varpro=True),
                                      preprocessing=PreprocessingOverrides(decimate=18))).to_dict()
    assert r["preprocessing"]["decimate"] == 18
    dip = [w for w in r["warnings"] if "friction dip" in w]
    assert len(dip) == 1 and dip[0].startswith("joint_2: its friction dip (vs ") and "--decimate 2 " in dip[0]
    vs = float(dip[0].split("(vs ", 1)[1].split(")", 1)[0])
    assert vs == pytest.approx(0.05, rel=0.1)


def test_thesis_protocol_de_runs_from_the_cli(capsys):
    """The command line of the issue (all parameters searched, a short budget here)."""
    from frictionid_core.cli import main

    code = main(["identify", str(BAGS / "tx40_j2_excitation"), "--system", "tx40-j2", "--joints", "joint_2",
                 "--friction", "stribeck", "--solver", "de", "--budget", "5"])
    assert code == 0
    assert "tx40-j2 · stribeck · solver de" in capsys.readouterr().out


def test_full_robot_on_the_bundled_bags():
    """At the true Stribeck shapes the closed form gives every determined base parameter and
    every friction level within 5 %, consistent bodies, and the noise floor on validation."""
    from frictionid_core.consistency import report_for_result
    from frictionid_core.systems import get_system

    est = load(BAGS / "tx40_excitation")
    model = build_model(est, "tx40", "stribeck", False)
    exp = expected_parameters(TRUTH["tx40_excitation"], "tx40")
    x, _ = model.solve_linear(np.array([[exp[n] for n in model.names]]))
    result = {"system": "tx40", "friction": "stribeck", "asymmetric": False, "joints": est.joints,
              "params": dict(zip(model.names, map(float, x[0]))), "std": {},
              "preprocessing": {"cutoff_hz": 50.0, "order": 4, "decimate": 1, "trim_start": 200, "trim_end": 200}}
    for name, value in result["params"].items():
        truth = exp[name]
        if "/F" in name or (name in TRUTH["tx40_excitation"]["base_parameters"] and abs(truth) > 0.01):
            assert value == pytest.approx(truth, rel=0.05), name
    rep = report_for_result(result, get_system("tx40"))
    assert rep["feasible"], rep["bodies"]
    summary = compare(dict(result, std=dict.fromkeys(result["params"], 0.001)), TRUTH["tx40_excitation"])["summary"]
    assert summary["parameters"] == model.k
    # resolvable to 5 % at 95 %: 1.96e-3 < 0.05 |truth|, i.e. |truth| > 0.0392 (zero truths never)
    assert summary["resolvable_5pct"] == sum(abs(exp[n]) > 1.96e-3 / 0.05 for n in model.names)
    assert 0 < summary["resolvable_5pct"] < model.k


def test_full_robot_system_holds_what_joint2_only_motion_leaves_still():
    """Joints that never move are held at their logged positions, by name: the fit is that of joint 2
    alone (--joints joint_2), the thesis model, and fits as it does."""
    series = load(BAGS / "tx40_j2_validation")
    whole = identify(series, IdentifyRequest(system="tx40", friction="coulomb"))
    assert whole.joints == ["joint_2"] and whole.unexcited_joints == ["joint_1", "joint_3", "joint_4", "joint_5",
                                                                       "joint_6"]
    robot = identify(series, IdentifyRequest(system="tx40", friction="coulomb", joints=["joint_2"]))
    assert whole.params == pytest.approx(robot.params, rel=1e-9, abs=1e-12)
    thesis = identify(series.select(["joint_2"]), IdentifyRequest(system="tx40-j2", friction="coulomb"))
    assert set(robot.held_joints) == {"joint_1", "joint_3", "joint_4", "joint_5", "joint_6"}
    assert robot.identifiability["rank"] == robot.identifiability["columns"] == len(thesis.params)
    assert robot.metrics["relerr_pct"] == pytest.approx(thesis.metrics["relerr_pct"], rel=1e-3)


@pytest.mark.slow
def test_full_robot_friction_within_5_percent_with_variable_projection():
    """On a robot system a population method searches only the friction shapes (12 here) and
    solves the base parameters and the friction levels in closed form; DE 10 × 3 and the LM
    polish (hybrid) fit the excitation bag better than the true parameters do (the least-squares
    optimum: a lower cost on the fit's own filtered, decimated rows) and put every friction
    parameter of the six joints within 5 % of the truth — but δ, within 10 % and 3 calibrated σ (a
    1.96 σ bound misses one parameter in twenty by design): at the cut-offs the folds choose with
    the joints' low-speed friction curve, the rule's 7.2–14.7 Hz raised to 46.4 Hz (0.50 % against
    0.68 %), every other friction parameter comes out within 0.1 %, δ of joint 2 −4.1 % (1.96 σ of
    2.1 %); at the rule's, δ of joint 2 came out +6.5 % (σ 12 %); raised by the dip refit to
    5.3–39.8 Hz, δ of joint 3 −7.6 %. The bag's 15 s of plateaus make that possible: σ(δ of joint 2)
    was 9.5 % on the former 20 s Fourier-only bag (bench/tx40_stribeck_information.py bounds it)."""
    est = load(BAGS / "tx40_excitation")
    r = identify(est, IdentifyRequest(system="tx40", friction="stribeck",
                                      solver=SolverOptions("hybrid", pop=10, generations=3))).to_dict()
    assert r["varpro"] is True
    exp = expected_parameters(TRUTH["tx40_excitation"], "tx40")
    model = build_model(est, "tx40", "stribeck", False, Preprocessing.from_dict(r["preprocessing"]))
    fit, truth = (np.array([[p[n] for n in model.names]]) for p in (r["params"], exp))
    assert model.batch_cost(fit)[0] <= model.batch_cost(truth)[0]
    rows = compare(r, TRUTH["tx40_excitation"])["parameters"]
    friction = {n: row for n, row in rows.items() if "/" in n and not n.endswith("/offset")}
    assert len(friction) == 30
    for name, row in friction.items():
        if name.endswith("/delta"):
            assert abs(row["relerr_pct"]) < 10.0 and abs(row["error"]) < 3.0 * r["std_robust"][name], (name, row)
            continue
        assert abs(row["relerr_pct"]) < 5.0, (name, row)
