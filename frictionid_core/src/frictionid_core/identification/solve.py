"""Solver glue: one fit of an identification model by its request's solver (closed form, an
optimiser of :mod:`frictionid_core.optim`, or a polish from a previous point), the problems the
optimisers see, the bounds the data ground (:func:`data_bounds`) and a law's linear special case
(Coulomb): its fit, the comparison on held-back rows and the fallback to it."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from frictionid_core.friction import DEFAULT_BOUNDS, get_model
from frictionid_core.identification.settings import SolverOptions
from frictionid_core.identification_model import IdentificationModel
from frictionid_core.parameter_names import parameter_kind

if TYPE_CHECKING:
    from frictionid_core.optim.problem import OptimResult, Problem

# A fit: (parameters (k,), σ {name: σ} or None, condition number or None, the optimiser's result or None).
Fit = tuple[np.ndarray, "dict[str, float] | None", "float | None", "OptimResult | None"]


def is_closed_form(model: IdentificationModel, solver: SolverOptions) -> bool:
    """True when ``solver`` solves ``model`` in closed form: ``ls``, or variable projection with
    no nonlinear parameter left to search."""
    return solver.method == "ls" or bool(solver.varpro and model.searched_nonlinear_index.size == 0)


def fit_model(model: IdentificationModel, solver: SolverOptions, progress=None,
              previous: tuple[np.ndarray, OptimResult] | None = None) -> Fit:
    """``solver`` (its ``varpro`` resolved) on ``model``: closed form (with σ and the condition
    number) or an optimiser. With ``previous`` (the point and result of a coarser round of the
    dip refit), a local solver (lm, hybrid's polish) only polishes from that point: the finer
    rates move the optimum, not its basin."""
    if is_closed_form(model, solver):
        return (*model.fit_linear(), None)
    if previous is not None and solver.method in ("lm", "hybrid"):
        polish = solver if solver.method == "lm" else SolverOptions(  # hybrid: the options of its polish
            "lm", solver.seed, calls=solver.calls, varpro=solver.varpro,
            options=solver.options.get("polish_options") or {})
        x, res = solve_model(model, polish, progress=progress, start=previous[0])
        return x, None, None, previous[1].refined(res, "dip refit at the finer rates: lm from this point")
    x, res = solve_model(model, solver, progress=progress)
    return x, None, None, res


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
    """Best of ``samples`` random nonlinear parameter sets (plus the lower corner, where the
    Stribeck/Threlfall dip vanishes and the model is the nested Coulomb one), each with its
    linear parameters solved in closed form: the start of local solvers (lm) and a member of
    the global methods' first population, so no solver returns worse than the nested model."""
    lo, hi = model.bounds()
    nl = model.nonlinear_index
    theta = np.zeros((samples + 1, model.k))
    theta[:, nl] = np.vstack([lo[nl], lo[nl] + (hi[nl] - lo[nl]) * rng.random((samples, nl.size))])
    full, cost = model.solve_linear(theta)
    return np.clip(full[int(np.argmin(cost))], lo, hi)


def full_problem(model: IdentificationModel) -> Problem:
    """The problem over every parameter that is not fixed."""
    from frictionid_core.optim.problem import Problem

    lo, hi = model.bounds()
    free = model.free_index

    def full(p: np.ndarray) -> np.ndarray:
        return model.embed(p, free)

    return Problem(names=[model.names[i] for i in free], lower=lo[free], upper=hi[free],
                   batch_cost=lambda p: model.batch_cost(full(p)), residuals=lambda p: model.residuals(full(p)[0]),
                   batch_residuals=lambda p: model.obs.y[None, :] - model.predict(full(p)))


def varpro_problem(model: IdentificationModel) -> Problem:
    """The reduced problem over the nonlinear parameters that are not fixed."""
    from frictionid_core.optim.problem import Problem

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
# Fs ≤ FS_FACTOR × the Coulomb special case's Fc of its joint and branch: a static friction many
# times the sliding level fits something else (a few rows near standstill, a transient).
FS_FACTOR = 3.0
# … where that Fc is below this share of the joint's largest |torque|, FS_FACTOR × that share.
FS_FLOOR_SHARE = 0.01
# Hold-out of the comparison with the linear special case: the instants split into HOLDOUT_BLOCKS
# contiguous blocks, every HOLDOUT_EVERY-th held back (a quarter of the log, spread over it).
HOLDOUT_BLOCKS = 20
HOLDOUT_EVERY = 4
# The law beats its linear case only when its held-back error is more than this share of the linear
# case's lower: on Coulomb data the two differ by ~1e-4 of it either way (a tie, no evidence).
HOLDOUT_MARGIN = 0.005


def linear_special_case(model: IdentificationModel) -> tuple[IdentificationModel, np.ndarray]:
    """(the Coulomb model nested in ``model``'s law: the same rows, rigid body, offsets, fixed
    values and bounds of the parameters it shares; its closed-form solution (k_c,))."""
    coulomb = get_model("coulomb", model.friction.asymmetric)
    names = {n for n in model.names if parameter_kind(n) not in ("Fs", *model.friction.law.nonlinear)}
    fixed = {model.names[i]: v for i, v in model.fixed_values.items() if model.names[i] in names}
    bounds = {model.names[i]: b for i, b in model.user_bounds.items() if model.names[i] in names}
    special = IdentificationModel(model.obs, coulomb, model.offset, model.rigid_bounds, bounds, fixed,
                                  physical=model.physical)
    return special, special.fit_linear()[0]


def special_case_parameters(model: IdentificationModel, x: np.ndarray, special: IdentificationModel,
                            x_special: np.ndarray) -> np.ndarray:
    """``model``'s parameters (k,) that predict what the Coulomb ``special`` case's ``x_special``
    does: its values by name, Fs = Fc (the dip's height 0: tustin, stribeck; vs and δ of ``x``
    kept, without effect), v0 at its lower bound (threlfall: below every used speed, no dip)."""
    value = dict(zip(special.names, x_special))
    lo, _ = model.bounds()
    out = np.array(x, dtype=float)
    for i, name in enumerate(model.names):
        base = name.rsplit("/", 1)[-1]
        if name in value:
            out[i] = value[name]
        elif base.startswith("Fs"):
            out[i] = value[name[: len(name) - len(base)] + "Fc" + base[2:]]
        elif base.startswith("v0") and i not in model.fixed_values:
            out[i] = lo[i]
    return out


def data_bounds(model: IdentificationModel) -> dict[str, tuple[float, float]]:
    """Bounds of a nonlinear law grounded in the data of ``model`` (docs/cli.md#constraints): vs
    and v0 within the used speeds of their joint [slowest, fastest], and within the law's default
    range (:data:`~frictionid_core.friction.DEFAULT_BOUNDS`: a search over decades of speed needs
    a cap) where the two overlap; Fs ≤ FS_FACTOR × the Coulomb
    special case's Fc of its joint and branch (at least FS_FACTOR × FS_FLOOR_SHARE × the joint's
    largest |torque|). {} for a linear law."""
    if model.is_linear:
        return {}
    obs = model.obs
    nd, nj = obs.n_samples, len(obs.joints)
    special = x_special = None
    out = {}
    for j, joint in enumerate(obs.joints):
        rows = slice(j * nd, (j + 1) * nd)
        speed = np.abs(obs.velocity[obs.used[rows], j])
        speed = speed[speed > 0.0]
        prefix = f"{joint}/" if nj > 1 else ""
        for name in model.friction.names:
            base = name.removesuffix("_pos").removesuffix("_neg")
            if base in ("vs", "v0") and speed.size and speed.max() > speed.min():
                lo, hi = DEFAULT_BOUNDS[base]
                out[prefix + name] = (max(float(speed.min()), lo), min(float(speed.max()), hi))
                if not out[prefix + name][0] < out[prefix + name][1]:  # the law's range misses the data's
                    out[prefix + name] = (float(speed.min()), float(speed.max()))
            elif base == "Fs":
                if special is None:
                    special, x_special = linear_special_case(model)
                fc = float(x_special[special.names.index(prefix + "Fc" + name[2:])])
                floor = FS_FLOOR_SHARE * float(np.max(np.abs(obs.y[rows]), initial=0.0))
                out[prefix + name] = (0.0, FS_FACTOR * max(fc, floor, np.finfo(float).tiny))
    return out


def with_data_bounds(model: IdentificationModel) -> IdentificationModel:
    """``model`` with its :func:`data_bounds` (the model itself for a linear law)."""
    bounds = data_bounds(model)
    if not bounds:
        return model
    return IdentificationModel(model.obs, model.friction, model.offset, model.rigid_bounds, model.bound_overrides,
                               model.fixed, bounds, model.physical)


def holdout_comparison(model: IdentificationModel, x: np.ndarray, solver: SolverOptions) -> dict:
    """The law of ``model`` against its linear special case on held-back rows: both fitted again
    on the other rows (the law by an lm polish from ``x``, or in closed form when nothing is
    searched; the Coulomb case in closed form), their relative errors [%] on the held-back rows;
    the law beats it when its error is more than HOLDOUT_MARGIN (0.5 %) of the linear case's lower.

    Returns {held_back_rows, law_relerr_pct, linear_relerr_pct, beats_linear}, or {skipped: why}
    when the training rows cannot be fitted (e.g. a joint that no longer moves both ways)."""
    from frictionid_core.errors import FrictionIdError

    nd = model.obs.n_samples
    held = (np.arange(nd) * HOLDOUT_BLOCKS // max(nd, 1)) % HOLDOUT_EVERY == HOLDOUT_EVERY - 1
    special, _ = linear_special_case(model)
    try:
        train = model.restricted(~held)
        if is_closed_form(train, solver):
            x_law = train.fit_linear()[0]
        else:
            polish = SolverOptions("lm", solver.seed, calls=solver.calls, varpro=solver.varpro)
            x_law = solve_model(train, polish, start=x)[0]
        x_lin = special.restricted(~held).fit_linear()[0]
    except FrictionIdError as exc:
        return {"skipped": str(exc)}
    rows = np.tile(held, len(model.obs.joints)) & model.obs.used
    scale = float(np.linalg.norm(model.obs.y[rows])) or 1.0
    law = float(np.linalg.norm(model.residuals(x_law)[rows]))
    linear = float(np.linalg.norm(special.residuals(x_lin)[rows]))
    return {"held_back_rows": int(rows.sum()), "law_relerr_pct": 100.0 * law / scale,
            "linear_relerr_pct": 100.0 * linear / scale, "beats_linear": bool(law < (1.0 - HOLDOUT_MARGIN) * linear)}


def linear_fallback(model: IdentificationModel, x: np.ndarray) -> tuple[np.ndarray, dict[str, float], float]:
    """(``model``'s parameters at its linear special case (Coulomb) fitted in closed form, their
    σ (Fs: Fc's; the dip's shape parameters: NaN, they have no effect), the condition number)."""
    special, x_special = linear_special_case(model)
    _, std_special, cond = special.fit_linear()
    out = special_case_parameters(model, x, special, x_special)
    std = {}
    for i, name in enumerate(model.names):
        base = name.rsplit("/", 1)[-1]
        if name in std_special:
            std[name] = std_special[name]
        elif base.startswith("Fs"):
            std[name] = std_special.get(name[: len(name) - len(base)] + "Fc" + base[2:], float("nan"))
        else:
            std[name] = 0.0 if i in model.fixed_values else float("nan")
    return out, std, cond
