"""Identification with optimisers on the EMPS bag: the population cost, variable projection,
global methods reaching the linear optimum, and the nesting rule."""

import json
from dataclasses import replace

import numpy as np
import pytest

from frictionid_core.cli import main
from frictionid_core.friction import all_models
from frictionid_core.identification import IdentifyRequest, SolverOptions, build_model, identify
from support.data import EMPS_ESTIMATION

MODELS = [(m.name, m.asymmetric) for m in all_models()]


@pytest.fixture(scope="module")
def coulomb_ls(emps_estimation):
    return identify(emps_estimation, IdentifyRequest(friction="coulomb", solver="ls"))


@pytest.mark.parametrize("friction,asym", MODELS)
def test_population_cost_equals_the_residual_of_the_prediction(emps_estimation, friction, asym):
    model = build_model(emps_estimation, "emps", friction, asym)
    lo, hi = model.bounds()
    pop = lo + (hi - lo) * np.random.default_rng(3).random((17, model.k))
    r = model.obs.y[None, :] - model.predict(pop)
    # Expanded quadratic form vs explicit residual: a few ulps of yᵀy (≈ 1e-13 of the cost) apart.
    np.testing.assert_allclose(model.batch_cost(pop), np.einsum("pr,pr->p", r, r), rtol=1e-12)


@pytest.mark.parametrize("friction,asym", MODELS)
def test_variable_projection_is_the_least_squares_optimum(emps_estimation, friction, asym):
    model = build_model(emps_estimation, "emps", friction, asym)
    lo, hi = model.bounds()
    pop = lo + (hi - lo) * np.random.default_rng(4).random((5, model.k))
    full, cost = model.solve_linear(pop)
    np.testing.assert_array_equal(full[:, model.nonlinear_index], pop[:, model.nonlinear_index])
    # The returned cost is the cost of the returned parameters ...
    np.testing.assert_allclose(cost, model.batch_cost(full), rtol=1e-9)
    # ... and no other choice of the linear parameters within their box (Fv, Fc, Fs, M ≥ 0) does
    # better (scipy's bounded least squares per candidate).
    from scipy.optimize import lsq_linear

    for i in range(len(pop)):
        X = model.design(full[i : i + 1])[0]
        coef = lsq_linear(X, model.obs.y, bounds=model.linear_box, tol=1e-12).x
        best = np.sum((model.obs.y - X @ coef) ** 2)
        assert cost[i] <= best * (1 + 1e-9)


@pytest.mark.parametrize("solver,options", [("de", {}), ("pso", {}), ("ga", {"mutation_rate": 0.2})])
def test_global_methods_reach_the_ls_optimum_on_coulomb(emps_estimation, coulomb_ls, solver, options):
    """Issue target: DE, PSO and GA at the thesis budget (50 × 100) reach the LS cost within 0.1 %.

    The GA needs a per-gene mutation rate of 0.2: with the thesis's 0.02 it stalls 0.5–70 %
    above the optimum (8 seeds), since only mutation and the blended cut gene create new values.
    """
    res = identify(emps_estimation, IdentifyRequest(solver=SolverOptions(solver, seed=1, options=options)))
    assert res.metrics["cost"] <= coulomb_ls.metrics["cost"] * 1.001
    assert res.optimizer["nfev"] >= 50 + 99 * 48  # 50 × 100 (ga does not re-evaluate its 2 elites)
    assert len(res.optimizer["history_fmin"]) == 100


@pytest.mark.parametrize("solver", ["bo", "dt"])
def test_surrogates_start_from_the_least_squares_optimum_of_a_linear_model(emps_estimation, coulomb_ls, solver):
    """Warm start on a model linear in its parameters: the first bo/dt call is the closed-form
    optimum, so no result is worse than ``ls`` (4.08 %; before, 100 calls ended at 8.19 % / 14.9 %).
    Tolerance 1e-9 relative: the start is solved by normal equations, ``ls`` by QR; they differ
    by ~cond²·eps ≈ 1e-13 in the parameters and the cost only to second order around its minimum."""
    surrogate = SolverOptions(solver, seed=3, calls=12, options={"n_initial_points": 10})
    res = identify(emps_estimation, IdentifyRequest(friction="coulomb", solver=surrogate))
    ls_cost = coulomb_ls.metrics["cost"]
    assert res.optimizer["history_fmin"][0] <= ls_cost * (1 + 1e-9)
    assert res.metrics["cost"] <= ls_cost * (1 + 1e-9)
    assert res.metrics["relerr_pct"] == pytest.approx(coulomb_ls.metrics["relerr_pct"], rel=1e-9)
    cold = identify(emps_estimation, IdentifyRequest(friction="coulomb", solver=replace(surrogate, warm_start=False)))
    assert cold.metrics["cost"] > 1.5 * ls_cost  # 12 random-ish calls do not find it by chance


def test_tustin_asymmetric_by_local_search_matches_the_thesis(emps_estimation, coulomb_ls):
    """Thesis Table 6.3: Tustin-asymmetric OSA relative error 3.0276 %; ours within 0.01 % of it with
    vs within the data's speeds (≤ 0.126 m/s; vs_neg 0.5, beyond every speed of the log, reached
    3.002 %), and never worse than the nested linear model (Coulomb-asymmetric, 3.1117 %). vs_neg ends at
    that bound, the fastest speed: not an identified value (at_bound, no σ); every other parameter has one."""
    res = identify(emps_estimation, IdentifyRequest(friction="tustin", asymmetric=True,
                                                    solver=SolverOptions("lm", varpro=True)))
    assert res.metrics["relerr_pct"] <= 3.0276 + 0.01
    top = res.velocity_range["emps"][1]
    assert res.params["vs_pos"] <= top and res.params["vs_neg"] <= top
    nested = identify(emps_estimation, IdentifyRequest(friction="coulomb", asymmetric=True, solver="ls"))
    assert res.metrics["cost"] <= nested.metrics["cost"]
    assert res.at_bound == {"vs_neg": pytest.approx(top)} and res.nonlinear_at_bound() == ["vs_neg"]
    assert np.isnan(res.std["vs_neg"]) and np.isfinite([v for n, v in res.std.items() if n != "vs_neg"]).all()


@pytest.mark.parametrize("friction", ["threlfall", "tustin", "stribeck"])
@pytest.mark.parametrize("asym", [False, True])
@pytest.mark.parametrize("solver", [SolverOptions("lm", varpro=True), SolverOptions("hybrid", pop=20, generations=20,
                                                                                    varpro=True)])
def test_nonlinear_models_never_worse_than_the_nested_linear_optimum(emps_estimation, friction, asym, solver):
    """Tustin, Stribeck and Threlfall contain Coulomb (vs, v0 → 0): a worse cost is a bug."""
    nested = identify(emps_estimation, IdentifyRequest(friction="coulomb", asymmetric=asym, solver="ls"))
    res = identify(emps_estimation, IdentifyRequest(friction=friction, asymmetric=asym, solver=solver))
    assert res.metrics["cost"] <= nested.metrics["cost"] * (1 + 1e-9)


@pytest.mark.parametrize("friction,asym", [("tustin", True), ("stribeck", False)])
@pytest.mark.parametrize("solver", ["de", "pso", "bbo"])
def test_global_search_over_all_parameters_never_worse_than_the_nested_linear_optimum(
        emps_estimation, friction, asym, solver):
    """The thesis protocol (every parameter searched, no variable projection) at a budget far
    too small to find the nested optimum alone: the closed-form start in the first population
    keeps the result at or below the nested Coulomb cost."""
    nested = identify(emps_estimation, IdentifyRequest(friction="coulomb", asymmetric=asym, solver="ls"))
    warm = IdentifyRequest(friction=friction, asymmetric=asym,
                           solver=SolverOptions(solver, varpro=False, pop=10, generations=3))
    res = identify(emps_estimation, warm)
    assert res.optimizer["nfev"] <= 30
    assert res.metrics["cost"] <= nested.metrics["cost"] * (1 + 1e-9)
    # the thesis protocol (random start) at this budget ends far above it
    cold = identify(emps_estimation, replace(warm, solver=replace(warm.solver, warm_start=False)))
    assert cold.warm_start is False and res.warm_start is True
    assert cold.metrics["cost"] > 1.2 * nested.metrics["cost"]


def test_cli_writes_optimiser_histories(tmp_path, capsys):
    out = tmp_path / "r.json"
    code = main(["identify", str(EMPS_ESTIMATION), "--friction", "tustin", "--solver", "de",
                 "--varpro", "--pop", "10", "--budget", "15", "--seed", "2", "--json", str(out)])
    assert code == 0
    d = json.loads(out.read_text())
    opt = d["optimizer"]
    assert opt["method"] == "de" and d["varpro"] is True
    assert len(opt["history_fmin"]) == 15 and len(opt["history_dist_mean"]) == 15
    assert np.all(np.diff(opt["history_fmin"]) <= 0)
    assert d["wall_s"] > 0 and set(d["params"]) == {"M", "Fv", "Fc", "Fs", "vs", "offset"}
    assert d["warm_start"] is True


def test_cli_no_warm_start_is_the_random_thesis_start(tmp_path):
    warm, cold = tmp_path / "warm.json", tmp_path / "cold.json"
    common = ["identify", str(EMPS_ESTIMATION), "--friction", "tustin", "--solver", "pso", "--pop", "10",
              "--budget", "3", "--seed", "1"]
    assert main(common + ["--json", str(warm)]) == 0
    assert main(common + ["--no-warm-start", "--json", str(cold)]) == 0
    w, c = json.loads(warm.read_text()), json.loads(cold.read_text())
    assert w["warm_start"] is True and c["warm_start"] is False
    assert w["metrics"]["cost"] < c["metrics"]["cost"]


def test_population_cost_does_not_depend_on_the_thread_count(emps_estimation):
    """The compiled dip sums give one candidate to one thread: bit-identical for 1, 2 or 3
    threads, and a NaN shape parameter gives a NaN cost (the optimisers rank it last)."""
    from frictionid_core.parallel import fixed_threads

    model = build_model(emps_estimation, "emps", "stribeck", True)
    lo, hi = model.bounds()
    pop = lo + (hi - lo) * np.random.default_rng(5).random((9, model.k))
    pop[4, model.nonlinear_index[0]] = np.nan
    with fixed_threads(1):
        one = model.batch_cost(pop)
    for n in (2, 3):
        with fixed_threads(n):
            np.testing.assert_array_equal(model.batch_cost(pop), one)
    np.testing.assert_array_equal(model.batch_cost(pop), one)
    assert np.isnan(one[4]) and np.isfinite(np.delete(one, 4)).all()
