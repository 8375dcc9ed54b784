"""One identification: data → pre-processing → model → solver → parameters + metrics."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_core.linear import least_squares
from frictionid_core.metrics import fit_metrics
from frictionid_core.model import IdentificationModel
from frictionid_core.systems import get_system, observe
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

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in ("system", "friction", "asymmetric", "solver", "source", "joints",
                                          "params", "std", "metrics", "wall_s")}
        d.update(self.extra)
        return d


def build_model(series: JointSeries, system: str, friction: str, asymmetric: bool) -> IdentificationModel:
    """The identification model of ``system`` + ``friction`` on the data of ``series``."""
    sys_ = get_system(system)
    obs = observe(series, sys_)
    return IdentificationModel(obs, get_model(friction, asymmetric), rigid_bounds=dict(sys_.rigid_bounds))


def identify(series: JointSeries, *, system: str = "emps", friction: str = "coulomb",
             asymmetric: bool = False, solver: str = "ls", seed: int = 0, **solver_options) -> Identification:
    """Identify the parameters of ``system`` with ``friction`` from ``series``.

    ``solver`` is ``ls`` (linear models only) or any method of :mod:`frictionid_core.optim`.
    """
    t0 = time.perf_counter()
    model = build_model(series, system, friction, asymmetric)
    std: dict[str, float] = {}
    extra: dict = {}
    if solver == "ls":
        if not model.is_linear:
            raise FrictionIdError(
                f"solver 'ls' needs a model linear in its parameters; '{model.friction.label}' has nonlinear "
                f"parameter(s) {[model.names[i] for i in model.nonlinear_index]}: use lm, de, pso, ga, … instead"
            )
        X = model.design()
        fit = least_squares(X, model.obs.y, [model.names[i] for i in model.linear_index])
        x = np.empty(model.k)
        x[model.linear_index] = fit.coef
        std = {model.names[i]: float(s) for i, s in zip(model.linear_index, fit.std)}
        cond = fit.cond
    else:
        from frictionid_core.optim import minimize
        from frictionid_core.optim.problem import Problem

        lo, hi = model.bounds()
        problem = Problem(names=list(model.names), lower=lo, upper=hi, batch_cost=model.batch_cost,
                          residuals=model.residuals)
        res = minimize(problem, solver, seed=seed, **solver_options)
        x = res.x
        extra["optimizer"] = res.to_dict()
        cond = float(np.linalg.cond(model.design(x[None])[0] if not model.is_linear else model.design()))
    metrics = fit_metrics(model.obs.y, model.predict(x))
    metrics["cond"] = cond
    metrics["samples"] = int(model.obs.y.size)
    return Identification(system, friction, asymmetric, solver, series.source, list(series.joints),
                          dict(zip(model.names, map(float, x))), std, metrics, time.perf_counter() - t0, extra)


def validate(series: JointSeries, params: dict) -> dict[str, float]:
    """Cross-test: metrics of the identified ``params`` (an :meth:`Identification.to_dict`) on ``series``."""
    try:
        model = build_model(series, params["system"], params["friction"], bool(params["asymmetric"]))
        values = params["params"]
        x = np.array([values[n] for n in model.names], dtype=float)
    except KeyError as exc:
        raise FrictionIdError(f"parameter file lacks {exc}; expected the JSON written by 'frictionid identify'") from None
    metrics = fit_metrics(model.obs.y, model.predict(x))
    metrics["samples"] = int(model.obs.y.size)
    return metrics
