"""One identification: data → pre-processing → model → solver → parameters + metrics."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING

import numpy as np

from frictionid_core import diagnostics
from frictionid_core.drive import Drive, result_drive
from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.friction import get_model
from frictionid_core.metrics import observation_metrics
from frictionid_core.identification_model import IdentificationModel
from frictionid_core.observation import Observation, concat_observations
from frictionid_core.parallel import single_threaded_libraries
from frictionid_core.preprocess import Preprocessing, dip_needs, rule_decimation
from frictionid_core.systems import System, as_system, observe, result_system
from frictionid_core.timeseries import JointSeries

if TYPE_CHECKING:
    from frictionid_core.optim.problem import OptimResult

# One source, or several fitted together.
Sources = JointSeries | Sequence[JointSeries]
# At most this many refits when a friction dip needs finer rates than those chosen (see identify).
DIP_ROUNDS = 4


@dataclass
class Identification:
    """What an identification produced (JSON-ready with :meth:`to_dict`)."""

    system: str
    friction: str
    asymmetric: bool
    solver: str
    source: str | list[str]  # a list when several sources were fitted together
    joints: list[str]
    params: dict[str, float]
    std: dict[str, float]
    metrics: dict[str, float]
    wall_s: float
    extra: dict = field(default_factory=dict)
    joint_map: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in ("system", "joint_map", "friction", "asymmetric", "solver", "source",
                                          "joints", "params", "std", "metrics", "wall_s", "warnings", "notes")}
        d.update(self.extra)
        return d


def build_model(series: Sources, system: str | System, friction: str, asymmetric: bool,
                preprocessing: Preprocessing | None = None,
                bounds: dict[str, tuple[float, float]] | None = None, *,
                joint_map: dict[str, str] | None = None, fixed: dict[str, float] | None = None) -> IdentificationModel:
    """The identification model of ``system`` (a name, with ``joint_map``, or a System) +
    ``friction`` on the data of ``series`` (one source or several: :func:`observe_sources`).

    ``preprocessing`` overrides the system's default; ``bounds`` are the user's bounds and
    ``fixed`` the parameters held at a value (see ``IdentificationModel``).
    """
    sys_ = as_system(system, joint_map)
    obs = observe_sources(series, sys_, preprocessing)
    return IdentificationModel(obs, get_model(friction, asymmetric),
                               rigid_bounds=sys_.parameter_bounds(as_sources(series)[0].joints),
                               bound_overrides=dict(bounds or {}), fixed=dict(fixed or {}))


def observe_sources(series: Sources, system: System, settings: Preprocessing | None = None) -> Observation:
    """The observation of one source, or of several with the same joints: each pre-processed
    alone (no filter runs across the seam between two recordings) with the settings the first
    source resolved (so one pre-processing describes the fit), then stacked per joint."""
    sources = as_sources(series)
    first = sources[0]
    for s in sources[1:]:
        if list(s.joints) != list(first.joints):
            raise InputError(f"{s.source}: joints {list(s.joints)} differ from those of {first.source}: "
                             f"{list(first.joints)}; the sources of one fit need the same joints (select with --joints)")
    obs = observe(first, system, settings)
    return concat_observations([obs] + [observe(s, system, obs.preprocessing) for s in sources[1:]])


def as_sources(series: Sources, window: tuple[float | None, float | None] | None = None) -> list[JointSeries]:
    """``series`` as a non-empty list of sources, each cut to ``window`` (start_s, end_s), s from
    its first sample (see :meth:`JointSeries.window`)."""
    sources = [series] if isinstance(series, JointSeries) else list(series)
    if not sources:
        raise FrictionIdError("no source given")
    return [s.window(*window) for s in sources] if window else sources


def window_record(window: tuple[float | None, float | None] | None) -> dict | None:
    """A window (start_s, end_s) as kept in a result: {"start_s", "end_s"} (s; None: open), or None."""
    return None if window is None else dict(zip(("start_s", "end_s"), window))


def _selection(sources: list[JointSeries], model: IdentificationModel, window,
               bounds: dict[str, tuple[float, float]] | None) -> dict:
    """The data selection of a result: source(s), window, fixed parameters, user bounds."""
    return {"source": sources[0].source if len(sources) == 1 else [s.source for s in sources],
            "window": window_record(window),
            "fixed": {model.names[i]: v for i, v in model.fixed_values.items()},
            "bounds": {name: [float(lo), float(hi)] for name, (lo, hi) in (bounds or {}).items()}}


# One BLAS thread: the tall products (FᵀF of the dip refit's 161k rows, the Jacobian's JᵀJ) gain
# nothing from a second one, and a thread parked behind a competing process stalls each call:
# large log (issue 15) at load ~4, 43.6 s → 24.7 s, every parameter bit for bit the same.
@single_threaded_libraries()
def identify(series: Sources, *, system: str | System = "emps", joint_map: dict[str, str] | None = None,
             friction: str = "coulomb", asymmetric: bool = False, solver: str = "ls", seed: int = 0,
             varpro: bool | None = None, warm_start: bool = True, preprocessing: Preprocessing | None = None,
             bounds: dict[str, tuple[float, float]] | None = None, fixed: dict[str, float] | None = None,
             window: tuple[float | None, float | None] | None = None, drive: Drive | None = None,
             progress=None, consistent: bool = False, prior: str | None = None, prior_weight: float = 1.0,
             stribeck_order: bool = False,
             **solver_options) -> Identification:
    """Identify the parameters of ``system`` with ``friction`` from ``series``.

    Args:
        series: one source, or several with the same joints (each pre-processed alone, the
            observations stacked).
        system: a system name (see :data:`frictionid_core.systems.SYSTEM_NAMES`) or a System.
        joint_map: {data joint: model joint} of a robot system named by ``system``.
        drive: the log's transmission (:func:`frictionid_core.drive.load_drive`): the log is taken
            to the joint side first; with ``friction_on: motor`` friction, offsets and rotor
            inertias are per motor (``motor_<k>/…``, fit in the referred motor torques) and the
            metrics are on the joint torques Cᵀ·u.
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
        preprocessing: filter/decimation settings (default: the system's; settings left None
            are chosen from the data, see :mod:`frictionid_core.preprocess`).
        bounds: {name: (lo, hi)} the user's bounds (see ``IdentificationModel``): they hold in
            every solver path, the closed-form linear parameters included.
        fixed: {name: value} parameters held at a value in every solver path (σ 0); a name is a
            full parameter name, a base name (``offset``) or a family (``vs``), as for bounds.
        window: (start_s, end_s) of every source, s from its first sample (None: all of it).
        progress: ``progress(generation, evaluations, best_cost)`` during an optimiser run (see
            :class:`frictionid_core.optim.Problem`); not called by ``ls``.
        consistent: robot systems: the final linear parameters are physically consistent
            standard parameters (:mod:`frictionid_core.robots.consistent_fit`) at the nonlinear shapes
            of the unconstrained solution; σ stay those of the unconstrained fit; the result
            gains ``standard_parameters`` and ``consistency``.
        prior: with ``consistent``: ``"urdf"`` pulls each link's pseudo-inertia toward the robot
            model's own (URDF/table) with the log-det divergence weighted by ``prior_weight``.
        stribeck_order: with ``consistent``: also Fs ≥ Fc (off by default: see the docs).
        **solver_options: budgets (pop, generations, calls) and method options.
    """
    t0 = time.perf_counter()
    sys_ = as_system(system, joint_map, drive)
    settings = preprocessing or sys_.preprocessing
    if varpro is None:
        varpro = sys_.robot is not None
    if consistent and sys_.robot is None:
        raise FrictionIdError(f"--consistent needs a robot system (tx40, urdf:PATH) with body parameters; "
                              f"system '{sys_.name}' has none")
    if prior not in (None, "none", "urdf"):
        raise FrictionIdError(f"prior '{prior}': expected 'urdf' (the robot model's own inertials) or none")
    if (prior == "urdf" or stribeck_order) and not consistent:
        raise FrictionIdError(f"{'a prior (--prior urdf)' if prior == 'urdf' else '--stribeck-order'} applies to the "
                              "consistent fit only: add --consistent")
    sources = as_sources(series, window)
    model = build_model(sources, sys_, friction, asymmetric, settings, bounds, fixed=fixed)
    errors, warnings = diagnostics.direction_problems(model.obs, [model.names[i] for i in model.free_index])
    if errors:
        raise InputError(f"{sources[0].source}: " + "; ".join(errors))
    extra: dict = {"drive": sys_.drive.to_dict() if sys_.drive else None, **_selection(sources, model, window, bounds)}
    closed_form = solver == "ls" or (varpro and model.searched_nonlinear_index.size == 0)

    def fit(model: IdentificationModel, previous: tuple[np.ndarray, OptimResult] | None = None):
        """The solver on ``model``; in a dip refit of a local solver (lm, hybrid's polish) only the
        polish, from the ``previous`` round's point: the finer rates move the optimum, not its basin."""
        if closed_form:
            return (*model.fit_linear(), None)
        if previous is not None and solver in ("lm", "hybrid"):
            options = solver_options if solver == "lm" else {  # hybrid: the options of its polish
                "calls": solver_options.get("calls"), **(solver_options.get("polish_options") or {})}
            x, polish = solve_model(model, "lm", seed=seed, varpro=varpro, progress=progress, start=previous[0],
                                    **options)
            return x, None, None, previous[1].refined(polish, "dip refit at the finer rates: lm from this point")
        x, res = solve_model(model, solver, seed=seed, varpro=varpro, warm_start=warm_start,
                              progress=progress, **solver_options)
        return x, None, None, res

    x, std, cond, res = fit(model)
    # A friction dip the chosen rates cannot follow: refit with the rates its estimate needs,
    # until they agree (too coarse a rate overestimates vs, so this may take a few rounds).
    for _ in range(DIP_ROUNDS):
        changes, why = _dip_changes(model, x)
        if not changes:
            break
        from_data = model.obs.report["from_data"]
        model = build_model(sources, sys_, friction, asymmetric, replace(settings, **changes), bounds, fixed=fixed)
        model.obs.report["from_data"] = sorted(set(from_data) | set(model.obs.report["from_data"]))
        model.obs.report["dip"] = why
        x, std, cond, res = fit(model, (x, res))
    warnings += _dip_warnings(model, x)
    if res is not None:
        extra["optimizer"] = res.to_dict()
        extra["varpro"] = varpro
        extra["warm_start"] = warm_start
        std, design = _jacobian_std(model, x)
        cond = float(np.linalg.cond(design))
    if consistent:
        x = _consistent(model, x, sys_, extra, prior == "urdf", prior_weight, stribeck_order)
    metrics = model_metrics(model, x)
    metrics["cost"] = float(model.batch_cost(x[None])[0])
    metrics["cond"] = cond
    obs = model.obs
    extra["preprocessing"] = preprocessing_record(obs, metrics, sys_.preprocessing, settings)
    lo, hi = model.bounds()
    free = model.free_index
    notes = [*(note for s in sources for note in s.notes), *obs.notes]
    warnings = (diagnostics.stamp_warnings(notes)
                + diagnostics.acceleration_warnings(obs.report, obs.preprocessing.cutoff_hz,
                                                    "cutoff_hz" in obs.report["from_data"])
                + warnings + diagnostics.parameter_warnings([model.names[i] for i in free], x[free], std,
                                                            lo[free], hi[free]))
    return Identification(sys_.name, friction, asymmetric, solver, extra.pop("source"), list(sources[0].joints),
                          dict(zip(model.names, map(float, x))), std, metrics, time.perf_counter() - t0, extra,
                          dict(sys_.joint_map), warnings, notes)


def _consistent(model: IdentificationModel, x: np.ndarray, sys_: System, extra: dict, use_prior: bool,
                prior_weight: float, stribeck_order: bool) -> np.ndarray:
    """The consistent parameters (see :func:`identify`); fills ``extra`` with the standard
    parameters and the ``consistency`` block (with the unconstrained fit's metrics)."""
    from frictionid_core.robots.consistency_check import standard_record
    from frictionid_core.robots.consistent_fit import consistent_fit

    unconstrained = model_metrics(model, x)
    fit = consistent_fit(model, x, sys_.robot, prior_weight=prior_weight if use_prior else 0.0,
                         stribeck_order=stribeck_order)
    fit.record["unconstrained"] = {"params": dict(zip(model.names, map(float, x))),
                                   "relerr_pct": unconstrained.get("relerr_pct"), "rmse": unconstrained.get("rmse")}
    fit.record["prior"] = "urdf" if use_prior else "none"
    extra["consistency"] = fit.record
    extra["standard_parameters"] = standard_record(sys_.robot, fit.names, fit.standard)
    return fit.x


def _dip_needs(model: IdentificationModel, x: np.ndarray) -> tuple[int, float, str, dict[str, float]]:
    """(largest decimation, smallest cut-off, why, {row joint: speed scale}) the friction dip of
    the fit ``x`` needs: see :func:`frictionid_core.preprocess.dip_needs`, for its speed scale
    (vs or v0) of each joint and branch at the joint's reversal acceleration (the smaller of a
    joint's two branches); a scale at its lower bound (a dip that vanished) is skipped."""
    obs = model.obs
    n_max, fc_min, why, scales = np.iinfo(np.int32).max, 0.0, "", {}
    if model.is_linear:
        return n_max, fc_min, why, scales
    lo, _ = model.bounds()
    fs = obs.report["sample_rate_hz"]
    scale = model.friction.law.nonlinear[0]
    for i in model.nonlinear_index:
        name = model.names[i]
        vanished = x[i] <= lo[i] and i not in model.fixed_values  # a searched dip at its lower bound
        if name.rsplit("/", 1)[-1].removesuffix("_pos").removesuffix("_neg") != scale or vanished:
            continue
        joint = name.split("/", 1)[0] if "/" in name else obs.joints[0]
        a = obs.report.get("reversal_acceleration", {}).get(joint) or 0.0
        n, fc = dip_needs(fs, a, x[i])
        scales[joint] = min(float(x[i]), scales.get(joint, np.inf))
        if n < n_max or fc > fc_min:
            why = (f"{joint}: its friction dip ({name} {x[i]:.3g}) is crossed at reversals at up to {a:.3g}/s²; "
                   f"it needs an analysis rate ≥ {fs / n:.4g} Hz and a cut-off ≥ {fc:.3g} Hz")
        n_max, fc_min = min(n, n_max), max(fc, fc_min)
    return n_max, fc_min, why, scales


def _dip_changes(model: IdentificationModel, x: np.ndarray) -> tuple[dict, str]:
    """The pre-processing changes (among the settings chosen from the data) the dip of ``x``
    needs, and why; {} when none.

    A decimation chosen from the data goes down to what the dip needs; the rows are then thinned
    (``thin``, ``dip_scale``: see :func:`frictionid_core.preprocess.thinned_rows`) back to the
    rule's rate for the cut-off wherever the dip is not crossed fast: the fine rate there only
    adds rows (and seconds and GBs on long logs)."""
    n, fc, why, scales = _dip_needs(model, x)
    pre, chosen = model.obs.preprocessing, model.obs.report["from_data"]
    changes = {}
    cutoff = pre.cutoff_hz
    if fc > cutoff * (1 + 1e-9) and "cutoff_hz" in chosen:
        cutoff = changes["cutoff_hz"] = fc
    if "decimate" in chosen:
        rule = rule_decimation(model.obs.report["sample_rate_hz"], cutoff)
        n = min(n, rule)
        if n < pre.decimate or changes:
            changes["decimate"] = n
            changes["thin"] = max(1, rule // n)
            changes["dip_scale"] = scales if changes["thin"] > 1 else None
    return changes, why


def _dip_warnings(model: IdentificationModel, x: np.ndarray) -> list[str]:
    """A warning when the settings the user gave are too coarse for the dip of ``x``."""
    n, fc, why, _ = _dip_needs(model, x)
    pre = model.obs.preprocessing
    if n >= pre.decimate and fc <= pre.cutoff_hz * (1 + 1e-9):
        return []
    return [f"{why} (here {model.obs.report['analysis_rate_hz']:.4g} Hz and {pre.cutoff_hz:.3g} Hz): vs and δ come out "
            f"biased; use --decimate {min(n, pre.decimate)} --cutoff {max(fc, pre.cutoff_hz):.3g}"]


def model_metrics(model: IdentificationModel, x: np.ndarray) -> dict:
    """:func:`~frictionid_core.metrics.observation_metrics` of the parameters ``x`` on the
    model's metric observation (the recorded effort at the analysis instants, predicted from
    the unfiltered columns there; or the model's own filtered rows under the EMPS protocol)."""
    on = metric_model(model)
    return observation_metrics(on.obs, on.predict(x))


def metric_model(model: IdentificationModel) -> IdentificationModel:
    """``model`` on its metric observation (:attr:`Observation.metric`: the recorded effort at the
    analysis instants with the unfiltered columns there, or its own rows under the EMPS protocol)."""
    obs = model.obs.metric
    return model if obs is model.obs else IdentificationModel(obs, model.friction, model.offset)


def preprocessing_record(obs, metrics: dict, default: Preprocessing, requested: Preprocessing) -> dict:
    """The JSON ``preprocessing`` block of an identification: the resolved settings of ``obs``,
    what the data said (its report, without the ``_``-keys), the torque noise floor of
    ``metrics``, and ``overridden``: the settings of ``requested`` that differ from the system's
    ``default``."""
    record = obs.preprocessing.to_dict()
    record.update({k: v for k, v in obs.report.items() if not k.startswith("_")})
    record["torque_noise_floor_pct"] = metrics.get("noise_floor_pct")
    record["overridden"] = [f.name for f in fields(Preprocessing)
                            if getattr(requested, f.name) != getattr(default, f.name)]
    return record


def solve_model(model: IdentificationModel, solver: str, *, seed: int = 0, varpro: bool = False,
                warm_start: bool = True, progress=None, start: np.ndarray | None = None, **solver_options):
    """Minimise the model's cost with ``solver``; returns (parameters (k,), OptimResult).

    Local solvers start from ``start`` (k,) if given (e.g. a previous fit), else from the best of
    a sample of closed-form solutions (:func:`_start_point`; for a model linear in its
    parameters, the least-squares optimum); with ``warm_start`` population methods and bo/dt
    evaluate that point first (as ``problem.x0``), linear models included. With ``varpro`` the
    solver sees only the nonlinear parameters; fixed parameters are never searched;
    ``progress``: see :func:`identify`.
    """
    from frictionid_core.optim import minimize

    searched = model.searched_nonlinear_index if varpro else model.free_index
    problem = _varpro_problem(model) if varpro else _full_problem(model)
    problem.progress = progress
    if start is not None:
        lo, hi = model.bounds()
        problem.x0 = np.clip(np.asarray(start, dtype=float), lo, hi)[searched]
    elif warm_start or solver == "lm":  # linear models too: their start is the least-squares optimum
        problem.x0 = _start_point(model, np.random.default_rng(seed))[searched]
    res = minimize(problem, solver, seed=seed, **solver_options)
    x = model.embed(res.x, searched)
    return (model.solve_linear(x)[0] if varpro else x)[0], res


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
    """The problem over every parameter that is not fixed."""
    from frictionid_core.optim.problem import Problem

    lo, hi = model.bounds()
    free = model.free_index

    def full(p: np.ndarray) -> np.ndarray:
        return model.embed(p, free)

    return Problem(names=[model.names[i] for i in free], lower=lo[free], upper=hi[free],
                   batch_cost=lambda p: model.batch_cost(full(p)), residuals=lambda p: model.residuals(full(p)[0]),
                   batch_residuals=lambda p: model.obs.y[None, :] - model.predict(full(p)))


def _varpro_problem(model: IdentificationModel):
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


def _jacobian_std(model: IdentificationModel, x: np.ndarray) -> tuple[dict[str, float], np.ndarray]:
    """σ of each estimate from the residual Jacobian at x: std(e)·sqrt(diag((JᵀJ)⁻¹)), and the
    design matrix at x (R, L).

    The prediction is linear in the linear parameters: their columns of J are the design
    matrix's; central differences for the free nonlinear ones (all perturbed predictions in one
    batched call); σ 0 for fixed parameters. NaN where J is rank-deficient (a parameter without
    influence, e.g. a dip that vanished).
    """
    free = model.free_index
    X = model.design(x[None])[0] if not model.is_linear else model.design()
    position = {int(i): k for k, i in enumerate(model.linear_index)}
    J = np.empty((X.shape[0], free.size))
    linear = np.array([k for k, i in enumerate(free) if int(i) in position], dtype=int)
    J[:, linear] = X[:, [position[int(free[k])] for k in linear]]
    nonlinear = np.setdiff1d(np.arange(free.size), linear)
    if nonlinear.size:
        index = free[nonlinear]
        h = 1e-6 * np.maximum(np.abs(x[index]), 1e-3)
        steps = np.zeros((index.size, model.k))
        steps[np.arange(index.size), index] = h
        pred = model.predict(np.vstack([x + steps, x - steps]))
        J[:, nonlinear] = (pred[: index.size] - pred[index.size :]).T / (2.0 * h)
    e = model.residuals(x)
    try:
        cov = np.linalg.inv(J.T @ J)
        sd = np.std(e, ddof=1) * np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        sd = np.full(free.size, np.nan)
    std = dict.fromkeys(model.names, 0.0)
    std.update((model.names[i], float(v)) for i, v in zip(free, sd))
    return std, X


def model_from_result(series: Sources, result: dict, *, system: str | None = None,
                      joint_map: dict[str, str] | None = None, joints: list[str] | None = None,
                      preprocessing: Preprocessing | None = None,
                      window: tuple[float | None, float | None] | None = None
                      ) -> tuple[IdentificationModel, np.ndarray]:
    """The model of an identification ``result`` (an :meth:`Identification.to_dict`) on ``series``
    (one source or several) and its identified parameters (k,).

    System, joint map, joints, friction, drive and pre-processing come from the result; each
    argument given overrides its part (``joint_map`` goes with ``system`` when both are given).
    ``window`` cuts ``series`` (s from the first sample); the result's own window is not reused.
    """
    try:
        if system is not None:
            sys_ = as_system(system, joint_map, result_drive(result))
        elif joint_map is not None:
            sys_ = as_system(result_system(result).name, joint_map, result_drive(result))
        else:
            sys_ = result_system(result)
        friction, asymmetric = result["friction"], bool(result["asymmetric"])
        joints = joints or result.get("joints")  # None (a hand-written file): the data's joints
        values = result["params"]
    except KeyError as exc:
        raise FrictionIdError(f"parameter file lacks {exc}; expected the JSON written by 'frictionid identify'") from None
    sources = as_sources(series, window)  # on the recorded side: the system's drive converts them
    if preprocessing is None and result.get("preprocessing"):
        preprocessing = Preprocessing.from_dict(result["preprocessing"], 1.0 / sources[0].dt)
    if joints:
        sources = [s.select(list(joints)) for s in sources]
    model = build_model(sources, sys_, friction, asymmetric, preprocessing)
    missing = [n for n in model.names if n not in values]
    if missing:
        raise FrictionIdError(f"parameter file lacks parameter(s) {missing} of the model (it has {list(values)}); "
                              "expected the JSON written by 'frictionid identify' for this system, joints and friction")
    return model, np.array([values[n] for n in model.names], dtype=float)


def validate(series: Sources, params: dict, **overrides) -> dict[str, float]:
    """Cross-test: metrics of the identified ``params`` (an :meth:`Identification.to_dict`) on ``series``,
    with the identification's system, joint map, joints, friction, drive and pre-processing;
    ``overrides`` as for :func:`model_from_result` (system, joint_map, joints, preprocessing, window)."""
    model, x = model_from_result(series, params, **overrides)
    return model_metrics(model, x)
