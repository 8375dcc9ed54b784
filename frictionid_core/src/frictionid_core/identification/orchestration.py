"""One identification: data → pre-processing → model (with the bounds the data ground) → solver (and
dip refit) → the law against its linear special case on held-back rows → σ (white and robust) →
consistent parameters → metrics, plausibility and warnings (:func:`identify`)."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from frictionid_core.consistency import plausibility_warnings
from frictionid_core.drive import drive_from_dict, load_drive
from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.friction import get_model
from frictionid_core.identification import diagnostics
from frictionid_core.identification.at_bound import fit_at_bound
from frictionid_core.identification.cross_validation import choose_by_cross_validation, choose_min_speed, record_choice
from frictionid_core.identification.dip_refit import dip_advice, fit_at_dip_rates, settled_dip_advice
from frictionid_core.identification.dynamic_fit import fit_dynamic
from frictionid_core.identification.effort_lag import (
    confirmed_effort_lags,
    law_judged_effort_lags,
    unjudged_effort_lags,
)
from frictionid_core.identification.effort_sign import checked_effort_sign
from frictionid_core.identification.identifiability import identifiability
from frictionid_core.identification.joint_weights import unweighted_model, weighted_model
from frictionid_core.identification.law_choice import AUTO, identify_auto
from frictionid_core.identification.linear_case import holdout_comparison, linear_fallback, with_data_bounds
from frictionid_core.identification.load_dependent_fit import fit_with_load
from frictionid_core.identification.model_building import (
    Sources,
    all_rows_relerr_pct,
    as_sources,
    build_model,
    model_metrics,
    preprocessing_record,
)
from frictionid_core.identification.plan import FitPlan, Holds, plan_fit
from frictionid_core.identification.plausibility import (
    check_fit,
    known_rigid_body_report,
    robot_plausibility,
    velocity_range,
)
from frictionid_core.identification.request import IdentifyRequest
from frictionid_core.identification.result import IdentifyResult
from frictionid_core.identification.solve import Fit, fit_static
from frictionid_core.identification.stick import exclude_stick_phases
from frictionid_core.identification.uncertainty import (
    calibration_scale,
    jacobian_std,
    robust_std,
    sigma_with_held,
    uncertainty_record,
    white_covariance,
)
from frictionid_core.model import IdentificationModel
from frictionid_core.parallel import single_threaded_libraries
from frictionid_core.systems import LINK_TORQUE, KnownRigidBody, System, as_system, known_rigid_body, nominal_parameters
from frictionid_core.timeseries import JointSeries


def request_system(request: IdentifyRequest) -> System:
    """The system of ``request``: its name with its joint map, reading its logs through its drive."""
    drive = request.drive
    if isinstance(drive, str):
        drive = load_drive(drive)
    elif drive is not None:
        drive = drive_from_dict(drive, "the request's drive")
    return as_system(request.system, request.joint_map, drive, request.gravity)


def request_sources(series: Sources, request: IdentifyRequest) -> list[JointSeries]:
    """``series`` as a list of sources cut to the request's window (the request's joints are
    selected by the fit's plan: :func:`~frictionid_core.identification.plan.plan_fit`)."""
    return as_sources(series, request.window)


# One BLAS thread: the tall products (FᵀF of the dip refit's 161k rows, the Jacobian's JᵀJ) gain
# nothing from a second one, and a thread parked behind a competing process stalls each call:
# a large log at load ~4 took 43.6 s instead of 24.7 s, every parameter bit for bit the same.
@single_threaded_libraries()
def identify(series: Sources, request: IdentifyRequest | None = None, *, progress=None) -> IdentifyResult:
    """Identify what ``request`` asks for (default: EMPS, Coulomb, ls) from ``series``: one source or
    several, each pre-processed alone, each with its own joints (:mod:`.plan`). ``progress(generation,
    evaluations, best_cost)``: called by an optimiser (:class:`frictionid_core.optim.Problem`; raising
    stops the run). A motor-side drive's friction, offsets and rotor inertias are per motor
    (``motor_<k>/…``), its metrics on the joint torques. Unresolved directions are held (at 0, or at
    the model's values with ``prior``: :mod:`.identifiability`), σ NaN; ``consistent`` keeps the
    unconstrained fit's σ. Every fit gets the effort-sign check, joint by joint
    (:mod:`.effort_sign`)."""
    t0 = time.perf_counter()
    request = IdentifyRequest() if request is None else request
    if not isinstance(request, IdentifyRequest):
        raise FrictionIdError(f"identify takes an IdentifyRequest, got {type(request).__name__}")

    def fit(data: Sources, asked: IdentifyRequest, keep: dict | None = None) -> IdentifyResult:
        return fit_request(data, asked, progress, keep)

    logged: dict = {}  # the as-logged fit's model, which the effort-sign check screens
    if request.friction == AUTO:  # the law that predicts best, its request the one the sign check refits
        first, asked = identify_auto(series, request, fit, logged)
    else:
        first, asked = fit(series, request, logged), request
    result = checked_effort_sign(fit, series, asked, first, logged_joints(series, request), logged.get("model"))
    if request.friction == AUTO:
        result = replace(result, request=request, law_choice=first.law_choice)
    return replace(result, wall_s=time.perf_counter() - t0)


def logged_joints(series: Sources, request: IdentifyRequest) -> list[str]:
    """The joints of every source, as the model names them (the request's joint map), in order."""
    names: list[str] = []
    for source in request_sources(series, request):
        names += [request.joint_map.get(j, j) for j in source.joints if request.joint_map.get(j, j) not in names]
    return names


def fit_request(series: Sources, request: IdentifyRequest, progress=None, keep: dict | None = None) -> IdentifyResult:
    """The fit of :func:`identify`, the log's effort signs as they are; ``keep["model"]`` receives
    its model at the rule's rates (the unresolved directions held). A dynamic law judges the effort
    lags the motion confirms with its own fit (:func:`~.effort_lag.law_judged_effort_lags`)."""
    if not get_model(request.friction).is_dynamic:
        return _fit_request(series, request, progress, keep)[0]
    kept: dict[int, dict] = {}  # each fit's keep, by the id of its sources

    def fit(sources: list[JointSeries]) -> IdentifyResult:
        return _fit_request(sources, request, progress, kept.setdefault(id(sources), {}))[0]

    result, taken = law_judged_effort_lags(as_sources(series), fit)
    if keep is not None:
        keep.update(kept[id(taken)])
    return result


class _TooSlow(Exception):
    """Joints of a fit that never move faster than their min speed, other rows fitted: {joint: why}."""

    def __init__(self, whys: dict[str, str]):
        super().__init__("; ".join(f"{j} {why}" for j, why in whys.items()))
        self.whys = whys


def _fit_request(series: Sources, request: IdentifyRequest, progress=None, keep: dict | None = None, *,
                 settle: bool = True) -> tuple[IdentifyResult, object]:
    """(:func:`fit_request`'s result, the advice of its dip warning or None); ``settle``: follow that
    advice (fit again at the rates it names) until it holds, and warn with the rates that hold. A
    joint that never moves faster than the min speed its velocity noise sets, beside others that
    do, is planned again as unexcited (not fitted, named in a warning) and the whole fit redone."""
    try:
        return _fit_plan_request(series, request, progress, keep, settle=settle)
    except _TooSlow as slow:
        return _fit_plan_request(series, request, progress, keep, settle=settle, slow=slow.whys)


def _fit_plan_request(series: Sources, request: IdentifyRequest, progress=None, keep: dict | None = None, *,
                      settle: bool = True, slow: dict[str, str] | None = None) -> tuple[IdentifyResult, object]:
    """:func:`_fit_request` with the joints ``slow`` left unfitted (:func:`plan_fit`)."""
    t0 = time.perf_counter()
    sys_ = request_system(request)
    settings = request.preprocessing.apply(sys_.preprocessing)
    solver = request.solver.resolved(sys_.robot is not None, request.friction)
    sources = request_sources(series, request)
    where = sources[0].source if len(sources) == 1 else ", ".join(s.source for s in sources)
    holds = Holds(dict(request.hold), request.hold_missing)
    plan = plan_fit(sources, sys_, request.joints, holds, slow=slow)
    rigid = known_rigid_body(plan.system) if request.known_rigid_body else None
    fixed_request = {**request.fixed, LINK_TORQUE: 1.0} if rigid else dict(request.fixed)

    def fit_plan_of(on: FitPlan) -> FitPlan:
        return replace(on, system=rigid.fit_system) if rigid else on

    # the effort's own lag the loader found: taken where the motion confirms it, else judged by the system's model
    # (at the rule's cut-offs: at those the folds choose from the lagged effort, a lower cut-off stands in for part
    # of the lag); a dynamic law's judged by its own fit in fit_request (its friction is late at reversals alike)
    confirmed = sources if get_model(request.friction).is_dynamic else confirmed_effort_lags(
        sources, fit_plan_of(plan),
        lambda srcs: fit_plan_of(plan_fit(srcs, sys_, request.joints, holds, slow=slow)), settings,
        request.asymmetric, fixed_request)
    if confirmed is not sources:
        sources = confirmed
        plan = plan_fit(sources, sys_, request.joints, holds, slow=slow)
    sys_ = plan.system
    held: dict[str, float] = {}  # the directions the data do not resolve, held (identifiability)
    fit_plan = fit_plan_of(plan)

    chosen, choice = settings, None
    if settings.cutoff_hz is None:  # those that predict best (a dynamic law raises them where it predicts better)
        folds: dict = {}
        cutoffs, choice = choose_by_cross_validation(fit_plan, settings, request.asymmetric, fixed_request, folds,
                                                     dips=has_static_dip(request.friction),
                                                     raised=not get_model(request.friction).is_dynamic)
        if cutoffs is not None:
            chosen = replace(settings, cutoff_hz=cutoffs)
            if settings.min_speed is None and not get_model(request.friction).law.nonlinear:
                # the rows left out as too slow, at those cut-offs (a law with a dip models them)
                speeds, choice["min_speed"] = choose_min_speed(fit_plan, settings, cutoffs, request.asymmetric,
                                                               fixed_request, folds.get("folds"))
                if speeds is not None:
                    chosen = replace(chosen, min_speed=speeds)

    def rebuild(pre) -> IdentificationModel:
        model = with_data_bounds(build_model(fit_plan, fit_plan.system, request.friction, request.asymmetric, pre,
                                             request.bounds, fixed={**fixed_request, **held},
                                             elements=request.elements))
        if choice is not None:
            record_choice(model.obs.report, choice)
        return model

    prior = nominal_parameters(sys_) if request.prior == "urdf" and rigid is None else None

    last: list = [None, None]  # the model last weighed and its joint-weighted model: the fit's, weighed once

    def weigh(m: IdentificationModel) -> IdentificationModel:
        if last[0] is not m:
            last[:] = [m, weighted_model(m)]
        return last[1]

    def fit(m: IdentificationModel, previous: Fit | None = None) -> Fit:  # weighted least squares over the joints
        return (fit_dynamic if m.friction.is_dynamic else fit_static)(weigh(m), solver, progress, previous)

    def fit_from(start) -> tuple:
        """The fit from the settings ``start``: (model, fit, its settings, identifiability, warnings,
        the model before any rate changed); ``held`` receives the directions held."""
        held.clear()
        model, fit_settings = exclude_stick_phases(rebuild(start), start)
        errors, warnings = diagnostics.direction_problems(model.obs, [model.names[i] for i in model.free_index])
        if errors and slow is None and any(j not in errors for j in model.obs.joints):
            speeds = model.obs.report.get("min_speed_rows", {})
            raise _TooSlow({j: f"never faster than its min speed {speeds.get(j, np.nan):.3g} (a lower --min-speed or "
                               "--cutoff fits it)" for j in errors})
        if errors:
            raise InputError(f"{where}: " + "; ".join(errors.values()))
        resolved = identifiability(model, prior)
        if resolved.held:
            held.update(resolved.held)
            model = replace(model, fixed={**fixed_request, **held})
        at_rule_rates = model
        model, first = fit_at_dip_rates(model, fit_settings, rebuild, fit)
        return model, first, fit_settings, resolved, warnings, at_rule_rates

    model, first, fit_settings, resolved, warnings, at_rule_rates = fit_from(chosen)
    folds_cutoffs = (choice or {}).get("cutoff_hz")
    if model.friction.is_dynamic and folds_cutoffs is not None and folds_cutoffs != choice.get("rule_cutoff_hz"):
        model, first, fit_settings, resolved, warnings, at_rule_rates = dynamic_start(
            (model, first, fit_settings, resolved, warnings, at_rule_rates), lambda: fit_from(settings), held)
    if keep is not None:
        keep["model"] = at_rule_rates
    if request.load_dependent:  # Fc_load: the closed form alternated with the rigid-body torque
        model, first = fit_with_load(model, first, warnings, fit)
    x, std, cond, res = first.x, first.std, first.cond, first.optim
    inertia_warnings = list(sys_.robot.model.inertia_warnings) if sys_.robot is not None else []
    advice = dip_advice(model, x)
    if advice is not None and settle:
        def refit(decimate: int, cutoff_hz: float):
            asked = replace(request, preprocessing=replace(request.preprocessing, decimate=decimate,
                                                           cutoff_hz=cutoff_hz))
            return _fit_request(series, asked, progress, settle=False)[1]

        advice = settled_dip_advice(advice, refit)
    warnings = (inertia_warnings + plan.warnings() + resolved.warning(sys_.robot is not None) + warnings
                + ([] if advice is None else [advice.warning()]))
    if model.friction.is_dynamic:
        warnings += unjudged_effort_lags(sources)
    if "dip_not_followed" in model.obs.report:
        warnings.append(f"{model.obs.report['dip_not_followed']}: fitted at the rates before; vs and δ may come out "
                        "biased")
    if "dip_noise_limited" in model.obs.report:
        warnings.append(f"{model.obs.report['dip_noise_limited']}: fitted at those cut-offs; vs and δ may come out "
                        "biased (a lower position noise resolves the dip)")
    model = weigh(model)  # σ, the comparisons and the consistent fit weigh the joints as the fit did
    if res is not None:
        std, design = jacobian_std(model, x, model.held_at_box(x))
        cond = float(np.linalg.cond(design))
    holdout = None
    if not model.is_linear and solver.warm_start and not model.friction.is_dynamic and not request.load_dependent:
        model, x, std, cond, holdout = against_linear_case(model, weigh(at_rule_rates), x, (std, cond), solver,
                                                           warnings)
    closed_form = res is None or solver.varpro or "returned" in (holdout or {})  # the linear part: the box holds it
    at_bound = fit_at_bound(model, x, {**std, **dict.fromkeys(held, float("nan"))}, closed_form)
    std = {**sigma_with_held(model, x, std, set(at_bound)), **dict.fromkeys(held, float("nan"))}
    undetermined = {n for n, v in std.items() if not np.isfinite(v)}
    std_robust, robust_cov, robust_names, bandwidth = robust_std(model, x, undetermined)
    consistency = standard = None
    if request.consistent:
        # dropped directions are free in the program (0 need not be physical); the prior's stay at its values
        released = {model.names.index(n) for n in held} if resolved.action == "dropped" else set()
        scale = calibration_scale(std, std_robust, model.obs.rigid_names)  # the data inform as the calibrated σ say
        x, consistency, standard = consistent_parameters(model, x, sys_, request, released, scale)
    metrics = model_metrics(model, x)
    metrics["cost"] = float(unweighted_model(model).batch_cost(x[None])[0])
    metrics["cond"] = cond
    check_fit(model, x, metrics, where)
    notes = [*(note for s in sources for note in s.notes), *model.obs.notes, *plan.notes()]
    warnings = result_warnings(model, x, std, notes, warnings, at_bound)
    params, std, std_robust, fixed, plausibility = reported_parameters(
        model, x, (std, std_robust, robust_names, robust_cov), held, rigid, sys_, standard, warnings, plan.held,
        (request.prior, request.prior_weight))
    return IdentifyResult(
        system=sys_.name, joint_map=dict(sys_.joint_map), friction=request.friction, asymmetric=request.asymmetric,
        solver=solver.method, source=sources[0].source if len(sources) == 1 else [s.source for s in sources],
        joints=list(plan.rows), params=params, std=std, metrics=metrics,
        wall_s=time.perf_counter() - t0, warnings=warnings, notes=notes,
        drive=sys_.drive.to_dict() if sys_.drive else None, window=request.window, fixed=fixed,
        bounds=dict(request.bounds), optimizer=None if res is None else res.to_dict(),
        varpro=None if res is None else solver.varpro, warm_start=None if res is None else solver.warm_start,
        consistency=consistency, standard_parameters=standard,
        preprocessing=preprocessing_record(model.obs, metrics, sys_.preprocessing, settings),
        identifiability=resolved.to_dict(), held_joints=dict(plan.held) if sys_.robot is not None else None,
        no_effort_joints=list(plan.no_effort), unexcited_joints=list(plan.unexcited), request=request,
        std_robust=std_robust, uncertainty=uncertainty_record(bandwidth, model), velocity_range=velocity_range(model),
        holdout=holdout, plausibility=plausibility, at_bound=at_bound), advice


def has_static_dip(friction: str) -> bool:
    """True for a static law with a dip (Stribeck, Tustin, Threlfall): its cut-offs are cross-validated
    with each joint's low-speed friction curve. A dynamic law's pre-sliding is no static curve (a LuGre
    joint in 0.1–3 mrad motions: the folds predict at ~50 % either way, and the curve moved the choice
    from 4.6 to 21.5 Hz, σ1 19 → 71 % off); its rates are judged by its own fit (:func:`dynamic_start`)."""
    law = get_model(friction).law
    return law.dip is not None and not law.is_dynamic


# A fit within this factor of the torque noise floor (its moving rows) is at the floor: no other start is tried.
AT_FLOOR = 1.1


def dynamic_start(from_folds: tuple, from_rule, held: dict[str, float]) -> tuple:
    """A dynamic law's fit (:func:`_fit_request`'s ``fit_from`` tuple) from the folds' cut-offs or from the
    rule's, whichever predicts its own log's effort better on every row.

    The folds judge a cut-off with the Coulomb model; where friction has pre-sliding (micro-motions,
    dwells) that model misses every small motion, and a lower cut-off, which smooths those motions
    away, scores better with it although the law that models them then sees none (a one-joint LuGre
    of 0.1–3 mrad motions: folds' 1 Hz, all rows 30 %; the rule's 8.8 Hz raised: 9 %). Where the rule
    misreads the log (a quantised encoder read as motion up to its cap) the folds' choice wins. Both
    fits have the same parameters, so their in-sample error on every row of the same log compares
    them; the report's ``cross_validation.dynamic_start`` keeps both figures and the start taken
    (``rule``: ``validate`` chooses the cut-off again as the rule and the law do; ``rule_failed``: why
    the rule's settings could not be fitted, the folds' then taken). A fit from the folds
    within AT_FLOOR × the noise floor on its moving rows is taken as it is (the rule's fit of a 4.5 kHz
    log can take minutes)."""
    metrics = model_metrics(from_folds[0], from_folds[1].x)
    if metrics["relerr_pct"] <= AT_FLOOR * metrics.get("noise_floor_pct", 0.0):
        return from_folds  # nothing left for another start to explain
    folds_held = dict(held)
    scores, failed = {"folds": all_rows_relerr_pct(metrics)}, {}
    try:
        rule = from_rule()
        scores["rule"] = all_rows_relerr_pct(model_metrics(rule[0], rule[1].x))
    except (FrictionIdError, _TooSlow) as exc:  # the rule's rows leave a column empty (a coarse encoder's min speed)
        rule, failed = None, {"rule_failed": str(exc)}
    taken = "rule" if rule is not None and scores["rule"] < scores["folds"] else "folds"
    if taken == "folds":
        held.clear()
        held.update(folds_held)
    out = rule if taken == "rule" else from_folds
    record = out[0].obs.report.get("cross_validation")
    if isinstance(record, dict):
        out[0].obs.report["cross_validation"] = {**record, "dynamic_start": {
            "all_rows_relerr_pct": scores, "taken": taken, **failed}}
    return out


def reported_parameters(model: IdentificationModel, x: np.ndarray, sigmas: tuple, held: dict[str, float],
                        rigid: KnownRigidBody | None, sys_: System, standard: dict | None, warnings: list[str],
                        held_joints: dict[str, float], prior: tuple[str | None, float] = (None, 1.0)
                        ) -> tuple[dict, dict, dict, dict, dict | None]:
    """(params, std, std_robust, fixed, plausibility) of a fit as its result reports them: by name,
    ``fixed`` without the directions held because the data do not resolve them; a known rigid
    body's in the robot's base parameters (:func:`known_rigid_body_report`); a robot fit's links
    judged against the model (their warnings appended to ``warnings``; the links of ``held_joints``, the
    model joints held still, kept as modelled). ``sigmas``: (std, std_robust, the robust covariance's
    names, that covariance); ``prior``: the fit's (``urdf`` or None) and its weight, for the warnings' way out."""
    std, std_robust, robust_names, robust_cov = sigmas
    params = dict(zip(model.names, map(float, x)))
    fixed = {model.names[i]: v for i, v in model.fixed_values.items() if model.names[i] not in held}
    plausibility = None
    if rigid is not None:
        white_names = [n for n in (model.names[i] for i in model.free_index) if np.isfinite(std.get(n, 0.0))]
        params, std, std_robust, fixed = known_rigid_body_report(
            rigid, model, x, std, std_robust, (white_names, white_covariance(model, x, white_names)),
            (robust_names, robust_cov))
    elif sys_.robot is not None:
        held_links = [j for j in held_joints if j in sys_.robot.model.joints]
        plausibility = robot_plausibility(params, sys_, standard, held_links)
        warnings += plausibility_warnings(plausibility, *prior)
    return params, std, std_robust, fixed, plausibility


def against_linear_case(model: IdentificationModel, linear_rates: IdentificationModel, x: np.ndarray,
                        uncertainty: tuple[dict, float], solver, warnings: list[str]) -> tuple:
    """(model, x, std, cond, holdout) after comparing the nonlinear law of ``model`` with its
    linear special case (Coulomb) on held-back rows: the law's fit as it is when it wins, else
    the Coulomb case fitted on ``linear_rates`` (the model at the rule's rates, before any dip
    refit) with a warning appended to ``warnings``."""
    std, cond = uncertainty
    holdout = holdout_comparison(model, x, solver)
    if holdout.get("beats_linear") is False:
        model = linear_rates
        x, std, cond = linear_fallback(model, x)
        holdout["returned"] = "linear special case"
        warnings.append(f"{model.friction.label} does not beat its linear special case (Coulomb) on the "
                        f"held-back quarter of the rows (relerr {holdout['law_relerr_pct']:.4g} % vs "
                        f"{holdout['linear_relerr_pct']:.4g} %): the Coulomb case is returned (Fs = Fc, no dip); "
                        "these data do not support the law's dip")
    return model, x, std, cond, holdout


def result_warnings(model: IdentificationModel, x: np.ndarray, std: dict[str, float], notes: list[str],
                    warnings: list[str], at_bound: dict[str, float] | None = None) -> list[str]:
    """Every warning of a fit: the stamps (from ``notes``), the accelerations, ``warnings`` (the
    directions, the dip, the linear special case) and the parameters (``at_bound``: at a bound,
    held at 0 by the sign constraint; undetermined, negative)."""
    obs = model.obs
    lo, hi = model.bounds()
    free = model.free_index
    physical = {model.names[i] for i in free if model.physical_bound(i)}
    return (diagnostics.stamp_warnings(notes)
            + diagnostics.acceleration_warnings(obs.report, obs.preprocessing.cutoff_hz,
                                                "cutoff_hz" in obs.report["from_data"])
            + warnings + diagnostics.parameter_warnings([model.names[i] for i in free], x[free], std,
                                                        lo[free], hi[free], physical, at_bound))


def consistent_parameters(model: IdentificationModel, x: np.ndarray, sys_: System, request: IdentifyRequest,
                          released: set[int] = frozenset(), data_scale: float = 1.0) -> tuple[np.ndarray, dict, dict]:
    """(the consistent parameters, the ``consistency`` record with the unconstrained fit's
    metrics, the standard parameters per link) at the nonlinear shapes of ``x``; ``released``:
    the indices of parameters held only because the data do not resolve them (the program
    leaves the rigid-body ones to the prior); ``data_scale``: the calibrated σ's variance over the
    white one (the directions the data do not determine are held at the model's links)."""
    from frictionid_core.consistency import consistent_fit, standard_record

    use_prior = request.prior == "urdf"
    unconstrained = model_metrics(model, x)
    fit = consistent_fit(model, x, sys_.robot, prior_weight=request.prior_weight if use_prior else 0.0,
                         stribeck_order=request.stribeck_order, released=released, data_scale=data_scale)
    fit.record["unconstrained"] = {"params": dict(zip(model.names, map(float, x))),
                                   "relerr_pct": unconstrained.get("relerr_pct"), "rmse": unconstrained.get("rmse")}
    fit.record["prior"] = "urdf" if use_prior else "none"
    return fit.x, fit.record, standard_record(sys_.robot, fit.names, fit.standard)
