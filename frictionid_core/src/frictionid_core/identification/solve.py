"""Solver glue: one fit (:class:`Fit`) of a static law's identification model by its request's
solver (closed form, an optimiser of :mod:`frictionid_core.optim`, or a polish from a previous
point) and the problems the optimisers see. A dynamic law's fit is :mod:`.dynamic_fit`; a law's
linear special case, the bounds it grounds and the fallback to it are :mod:`.linear_case`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from frictionid_core.identification.feature_starts import dip_start
from frictionid_core.identification.settings import SolverOptions
from frictionid_core.model import IdentificationModel

if TYPE_CHECKING:
    from frictionid_core.optim import OptimResult, Problem



@dataclass(frozen=True)
class Fit:
    """One fit of an identification model: its parameters ``x`` (k,); for a closed form, σ by name
    (``std``) and the condition number (``cond``); for an optimiser, its result (``optim``)."""

    x: np.ndarray
    std: dict[str, float] | None = None
    cond: float | None = None
    optim: OptimResult | None = None


def is_closed_form(model: IdentificationModel, solver: SolverOptions) -> bool:
    """True when ``solver`` solves ``model`` in closed form: ``ls``, or variable projection with
    no nonlinear parameter left to search."""
    return solver.method == "ls" or bool(solver.varpro and model.searched_nonlinear_index.size == 0)


def fit_static(model: IdentificationModel, solver: SolverOptions, progress=None, previous: Fit | None = None) -> Fit:
    """``solver`` (its ``varpro`` resolved) on ``model`` of a static law: closed form (with σ and
    the condition number) or an optimiser. With ``previous`` (the fit of a coarser round of the
    dip refit, by an optimiser), a local solver (lm, hybrid's polish) only polishes from its point:
    the finer rates move the optimum, not its basin. ``ls`` on a law with shape parameters to
    search (vs, δ, …) is variable projection with ``lm``, as for the dynamic laws."""
    if solver.method == "ls" and model.searched_nonlinear_index.size:
        solver = SolverOptions("lm", solver.seed, calls=solver.calls, varpro=True)
    if is_closed_form(model, solver):
        return Fit(*model.fit_linear())
    if previous is not None and solver.method in ("lm", "hybrid"):
        polish = solver if solver.method == "lm" else SolverOptions(  # hybrid: the options of its polish
            "lm", solver.seed, calls=solver.calls, varpro=solver.varpro,
            options=solver.options.get("polish_options") or {})
        x, res = solve_model(model, polish, progress=progress, start=previous.x)
        return Fit(x, optim=previous.optim.refined(res, "dip refit at the finer rates: lm from this point"))
    x, res = solve_model(model, solver, progress=progress)
    x, res = polished(model, solver, x, res, progress)
    return Fit(x, optim=res)


def polished(model: IdentificationModel, solver: SolverOptions, x: np.ndarray, res: OptimResult,
             progress=None) -> tuple[np.ndarray, OptimResult]:
    """(parameters, result) of a global search (a population method, bo, dt) of the shape
    parameters (``varpro``) polished by lm from its best point when it ran with the closed-form
    start (``warm_start``): a search ends where its budget does, not at the optimum (bo and dt with
    100 calls on TX40 joint-2-like logs returned their start, δ 1.00 for 0.67); the polish is kept
    when it lowers the cost. A search of every parameter (``--no-varpro``) or without the warm
    start (the thesis protocol) keeps its own answer."""
    from frictionid_core.optim import POPULATION_METHODS

    if not (solver.warm_start and solver.varpro) or solver.method in ("ls", "lm", "hybrid") or model.is_linear:
        return x, res
    lm = SolverOptions("lm", solver.seed, varpro=True)
    report = None
    if progress is not None:  # the polish continues the search's count: its last generation, its evaluations on
        last = len(res.history_fmin) if solver.method in POPULATION_METHODS else 0

        def report(generation: int, evaluations: int, best: float) -> None:
            progress(last, res.nfev + evaluations, min(best, res.fun))

    x_lm, res_lm = solve_model(model, lm, progress=report, start=x)
    if not res_lm.fun <= res.fun:
        return x, res
    return x_lm, res.refined(res_lm, "polished by lm from the search's best point")


def solve_model(model: IdentificationModel, solver: SolverOptions, *, progress=None,
                start: np.ndarray | None = None) -> tuple[np.ndarray, OptimResult]:
    """Minimise the model's cost with the optimiser of ``solver``; returns (parameters (k,), OptimResult).

    Local solvers start from ``start`` (k,) if given (e.g. a previous fit), else from the best of
    a sample of closed-form solutions (:func:`start_point`; for a model linear in its
    parameters, the least-squares optimum); with ``solver.warm_start`` population methods and
    bo/dt evaluate that point first (as ``problem.x0``), linear models included. With
    ``solver.varpro`` the optimiser sees only the nonlinear parameters; fixed parameters are never
    searched. ``progress(generation, evaluations, best_cost)``: see :class:`frictionid_core.optim.Problem`.
    """
    from frictionid_core.optim import minimize

    varpro = bool(solver.varpro)
    searched = model.searched_nonlinear_index if varpro else model.free_index
    problem = varpro_problem(model) if varpro else full_problem(model)
    problem.progress = progress
    if start is not None:
        lo, hi = model.bounds()
        problem.x0 = np.clip(np.asarray(start, dtype=float), lo, hi)[searched]
    elif solver.warm_start or solver.method == "lm":  # linear models too: their start is the least-squares optimum
        problem.x0 = start_point(model, np.random.default_rng(solver.seed))[searched]
    res = minimize(problem, solver.method, seed=solver.seed, pop=solver.pop, generations=solver.generations,
                   calls=solver.calls, **solver.options)
    x = model.embed(res.x, searched)
    return (model.solve_linear(x)[0] if varpro else x)[0], res


def start_point(model: IdentificationModel, rng: np.random.Generator, samples: int = 64) -> np.ndarray:
    """Best of ``samples`` random nonlinear parameter sets, the lower corner (where the
    Stribeck/Threlfall dip vanishes and the model is the nested Coulomb one) and the dip read off
    the data's low-speed friction curve (:func:`~.feature_starts.dip_start`), each with its linear
    parameters solved in closed form — and, with the dips of several joints, the set that takes for
    each dip the sample that fits its joint's rows best (a sample is drawn for every joint at once:
    the best of them can hold one joint's dip in a wrong basin), where it costs less: the start of
    local solvers (lm) and a member of the global methods' first population, so no solver returns
    worse than the nested model."""
    lo, hi = model.bounds()
    nl = model.nonlinear_index
    theta = np.zeros((samples + 1, model.k))
    theta[:, nl] = np.vstack([lo[nl], lo[nl] + (hi[nl] - lo[nl]) * rng.random((samples, nl.size))])
    feature = dip_start(model)
    if feature is not None:
        theta = np.vstack([theta, np.clip(feature, lo, hi)[None]])
    full, cost = model.solve_linear(theta)
    best = int(np.argmin(cost))
    rows = model.dip_rows()
    if len({r.start for r, _ in rows}) > 1:  # the dips of several joints: each its own best sample
        errors = np.vstack([_dip_errors(model, full[i : i + 8], rows) for i in range(0, len(full), 8)])
        joint_wise = theta[best].copy()
        for d, (_, index) in enumerate(rows):
            joint_wise[index] = theta[int(np.argmin(errors[:, d])), index]
        full_jw, cost_jw = model.solve_linear(joint_wise[None])
        if cost_jw[0] < cost[best]:
            return np.clip(full_jw[0], lo, hi)
    return np.clip(full[best], lo, hi)


def _dip_errors(model: IdentificationModel, full: np.ndarray, rows: list[tuple[slice, np.ndarray]]) -> np.ndarray:
    """(P, D) the squared residual of the parameters ``full`` (P, k) on the rows of each dip."""
    squared = (model.obs.y[None] - model.predict(full)) ** 2
    return np.column_stack([squared[:, r].sum(axis=1) for r, _ in rows])


def full_problem(model: IdentificationModel) -> Problem:
    """The problem over every parameter that is not fixed."""
    from frictionid_core.optim import Problem

    lo, hi = model.bounds()
    free = model.free_index

    def full(p: np.ndarray) -> np.ndarray:
        return model.embed(p, free)

    return Problem(names=[model.names[i] for i in free], lower=lo[free], upper=hi[free],
                   batch_cost=lambda p: model.batch_cost(full(p)), residuals=lambda p: model.residuals(full(p)[0]),
                   batch_residuals=lambda p: model.obs.y[None, :] - model.predict(full(p)))


def varpro_problem(model: IdentificationModel) -> Problem:
    """The reduced problem over the nonlinear parameters that are not fixed."""
    from frictionid_core.optim import Problem

    lo, hi = model.bounds()
    nl = model.searched_nonlinear_index

    def cost(theta_nl: np.ndarray) -> np.ndarray:
        return model.solve_linear(model.embed(theta_nl, nl))[1]

    def residuals(theta_nl: np.ndarray) -> np.ndarray:
        return model.residuals(model.solve_linear(model.embed(theta_nl, nl))[0][0])

    def batch_residuals(theta_nl: np.ndarray) -> np.ndarray:
        return model.obs.y[None, :] - model.predict(model.solve_linear(model.embed(theta_nl, nl))[0])

    return Problem(names=[model.names[i] for i in nl], lower=lo[nl], upper=hi[nl], batch_cost=cost,
                   residuals=residuals, batch_residuals=batch_residuals)


# ----------------------------------------------------------------------- the law's linear special case
