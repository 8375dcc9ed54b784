"""One identification: data → pre-processing → model → solver → parameters + metrics."""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_core.linear import least_squares
from frictionid_core.metrics import fit_metrics
from frictionid_core.model import IdentificationModel
from frictionid_core.preprocess import Preprocessing
from frictionid_core.systems import System, as_system, observe, result_system
from frictionid_core.timeseries import JointSeries


@dataclass
class Identification:
    """What an identification produced (JSON-ready with :meth:`to_dict`)."""

    system: str
    friction: str
    asymmetric: bool
    solver: str
    source: str
    joints: list[str]
    params: dict[str, float]
    std: dict[str, float]
    metrics: dict[str, float]
    wall_s: float
    extra: dict = field(default_factory=dict)
    joint_map: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in ("system", "joint_map", "friction", "asymmetric", "solver", "source",
                                          "joints", "params", "std", "metrics", "wall_s")}
        d.update(self.extra)
        return d


def build_model(series: JointSeries, system: str | System, friction: str, asymmetric: bool,
                preprocessing: Preprocessing | None = None,
                bounds: dict[str, tuple[float, float]] | None = None, *,
                joint_map: dict[str, str] | None = None) -> IdentificationModel:
    """The identification model of ``system`` (a name, with ``joint_map``, or a System) +
    ``friction`` on the data of ``series``.

    ``preprocessing`` overrides the system's default; ``bounds`` overrides search bounds.
    """
    sys_ = as_system(system, joint_map)
    obs = observe(series, sys_, preprocessing)
    return IdentificationModel(obs, get_model(friction, asymmetric), rigid_bounds=dict(sys_.rigid_bounds),
                               bound_overrides=dict(bounds or {}))


def identify(series: JointSeries, *, system: str | System = "emps", joint_map: dict[str, str] | None = None,
             friction: str = "coulomb", asymmetric: bool = False, solver: str = "ls", seed: int = 0,
             varpro: bool | None = None, warm_start: bool = True, preprocessing: Preprocessing | None = None,
             bounds: dict[str, tuple[float, float]] | None = None, **solver_options) -> Identification:
    """Identify the parameters of ``system`` with ``friction`` from ``series``.

    Args:
        system: a system name (see :data:`frictionid_core.systems.SYSTEM_NAMES`) or a System.
        joint_map: {data joint: model joint} of a robot system named by ``system``.
        friction: the friction law (one of :data:`frictionid_core.friction.FRICTIONS`).
        solver: ``ls`` (models linear in their parameters) or any method of
            :mod:`frictionid_core.optim` (lm, ga, aco, bbo, de, pso, bo, dt, hybrid).
        seed: seed of stochastic solvers.
        varpro: variable projection: the solver searches only the nonlinear friction
            parameters (vs, delta, v0); every other parameter is solved in closed form for each
            candidate. Linear models are then solved by ``ls``. None (default): on for the
            robot systems (``tx40``, ``urdf:PATH``), whose tens of base parameters a global
            search over every parameter does not find; off otherwise (the thesis protocol).
        warm_start: global solvers (population methods, bo, dt) evaluate the closed-form start
            point first (see :func:`solve_model`), so no result is worse than the nested linear
            model; False gives them a purely random start, the thesis protocol.
        preprocessing: filter/decimation settings (default: the system's).
        bounds: {name: (lo, hi)} search-bound overrides (see ``IdentificationModel``).
        **solver_options: budgets (pop, generations, calls) and method options.
    """
    t0 = time.perf_counter()
    sys_ = as_system(system, joint_map)
    settings = preprocessing or sys_.preprocessing
    if varpro is None:
        varpro = sys_.robot is not None
    model = build_model(series, sys_, friction, asymmetric, settings, bounds)
    extra: dict = {"preprocessing": asdict(settings)}
    if solver == "ls" or (varpro and model.is_linear):
        if not model.is_linear:
            raise FrictionIdError(
                f"solver 'ls' needs a model linear in its parameters; '{model.friction.label}' has nonlinear "
                f"parameter(s) {[model.names[i] for i in model.nonlinear_index]}: use lm, de, pso, ga, … instead"
            )
        fit = least_squares(model.design(), model.obs.y, [model.names[i] for i in model.linear_index])
        x = np.empty(model.k)
        x[model.linear_index] = fit.coef
        std = {model.names[i]: float(s) for i, s in zip(model.linear_index, fit.std)}
        cond = fit.cond
    else:
        x, res = solve_model(model, solver, seed=seed, varpro=varpro, warm_start=warm_start, **solver_options)
        extra["optimizer"] = res.to_dict()
        extra["varpro"] = varpro
        extra["warm_start"] = warm_start
        std = _jacobian_std(model, x)
        cond = float(np.linalg.cond(model.design(x[None])[0]))
    metrics = fit_metrics(model.obs.y, model.predict(x))
    metrics["cost"] = float(model.batch_cost(x[None])[0])
    metrics["cond"] = cond
    metrics["samples"] = int(model.obs.y.size)
    return Identification(sys_.name, friction, asymmetric, solver, series.source, list(series.joints),
                          dict(zip(model.names, map(float, x))), std, metrics, time.perf_counter() - t0, extra,
                          dict(sys_.joint_map))


def solve_model(model: IdentificationModel, solver: str, *, seed: int = 0, varpro: bool = False,
                warm_start: bool = True, **solver_options):
    """Minimise the model's cost with ``solver``; returns (parameters (k,), OptimResult).

    Local solvers start from the best of a sample of closed-form solutions (:func:`_start_point`;
    for a model linear in its parameters, the least-squares optimum); with ``warm_start``
    population methods and bo/dt evaluate it first (as ``problem.x0``), linear models included.
    With ``varpro`` the solver sees only the nonlinear parameters.
    """
    from frictionid_core.optim import minimize

    problem = _varpro_problem(model) if varpro else _full_problem(model)
    if warm_start or solver == "lm":  # linear models too: their start is the least-squares optimum
        start = _start_point(model, np.random.default_rng(seed))
        problem.x0 = start[model.nonlinear_index] if varpro else start
    res = minimize(problem, solver, seed=seed, **solver_options)
    x = model.solve_linear(_embed(model, res.x))[0][0] if varpro else res.x
    return x, res


def _start_point(model: IdentificationModel, rng: np.random.Generator, samples: int = 64) -> np.ndarray:
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


def _full_problem(model: IdentificationModel):
    from frictionid_core.optim.problem import Problem

    lo, hi = model.bounds()
    return Problem(names=list(model.names), lower=lo, upper=hi, batch_cost=model.batch_cost,
                   residuals=model.residuals, batch_residuals=lambda p: model.obs.y[None, :] - model.predict(p))


def _embed(model: IdentificationModel, theta_nl: np.ndarray) -> np.ndarray:
    """Full parameter rows (P, k) holding the nonlinear parameters ``theta_nl`` (P, m)."""
    theta_nl = np.atleast_2d(theta_nl)
    full = np.zeros((theta_nl.shape[0], model.k))
    full[:, model.nonlinear_index] = theta_nl
    return full


def _varpro_problem(model: IdentificationModel):
    """The reduced problem over the nonlinear parameters only."""
    from frictionid_core.optim.problem import Problem

    lo, hi = model.bounds()
    nl = model.nonlinear_index

    def cost(theta_nl: np.ndarray) -> np.ndarray:
        return model.solve_linear(_embed(model, theta_nl))[1]

    def residuals(theta_nl: np.ndarray) -> np.ndarray:
        return model.residuals(model.solve_linear(_embed(model, theta_nl))[0][0])

    def batch_residuals(theta_nl: np.ndarray) -> np.ndarray:
        return model.obs.y[None, :] - model.predict(model.solve_linear(_embed(model, theta_nl))[0])

    return Problem(names=[model.names[i] for i in nl], lower=lo[nl], upper=hi[nl], batch_cost=cost,
                   residuals=residuals, batch_residuals=batch_residuals)


def _jacobian_std(model: IdentificationModel, x: np.ndarray) -> dict[str, float]:
    """σ of each estimate from the residual Jacobian at x: std(e)·sqrt(diag((JᵀJ)⁻¹)).

    Central differences, all 2k perturbed predictions in one batched call. NaN where J is
    rank-deficient (a parameter without influence, e.g. a dip that vanished).
    """
    h = 1e-6 * np.maximum(np.abs(x), 1e-3)
    steps = np.diag(h)
    pred = model.predict(np.vstack([x + steps, x - steps]))
    J = (pred[: model.k] - pred[model.k :]).T / (2.0 * h)
    e = model.residuals(x)
    try:
        cov = np.linalg.inv(J.T @ J)
        sd = np.std(e, ddof=1) * np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        sd = np.full(model.k, np.nan)
    return {n: float(v) for n, v in zip(model.names, sd)}


def validate(series: JointSeries, params: dict) -> dict[str, float]:
    """Cross-test: metrics of the identified ``params`` (an :meth:`Identification.to_dict`) on ``series``,
    with the identification's system (and joint map), pre-processed as in the identification."""
    try:
        settings = Preprocessing(**params["preprocessing"]) if "preprocessing" in params else None
        model = build_model(series, result_system(params), params["friction"], bool(params["asymmetric"]),
                            settings)
        values = params["params"]
        x = np.array([values[n] for n in model.names], dtype=float)
    except KeyError as exc:
        raise FrictionIdError(f"parameter file lacks {exc}; expected the JSON written by 'frictionid identify'") from None
    metrics = fit_metrics(model.obs.y, model.predict(x))
    metrics["samples"] = int(model.obs.y.size)
    return metrics
