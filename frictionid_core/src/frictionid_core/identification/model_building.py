"""The identification model of data: sources → plan → observation → :class:`IdentificationModel`, and its metrics."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields, replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_core.identification.plan import FitPlan, SourcePlan, plan_fit
from frictionid_core.model import (
    VELOCITY_COLUMNS,
    IdentificationModel,
    Observation,
    all_rows_metrics,
    concat_observations,
    observation_metrics,
)
from frictionid_core.preprocess import Preprocessing, choose_preprocessing, cutoff_range, resample_uniform
from frictionid_core.systems import System, as_system, observe
from frictionid_core.timeseries import JointSeries

# One source, or several fitted together.
Sources = JointSeries | Sequence[JointSeries]


def build_model(series: Sources | FitPlan, system: str | System, friction: str, asymmetric: bool,
                preprocessing: Preprocessing | None = None,
                bounds: dict[str, tuple[float, float]] | None = None, *,
                joint_map: dict[str, str] | None = None, fixed: dict[str, float] | None = None,
                elements: int | None = None) -> IdentificationModel:
    """The identification model of ``system`` (a name, with ``joint_map``, or a System) +
    ``friction`` (a Maxwell-slip law's ``elements``) on the data of ``series`` (one source or
    several: :func:`observe_sources`; or the :class:`FitPlan` of sources, whose own system is then
    the one fitted).

    ``preprocessing`` overrides the system's default; ``bounds`` are the user's bounds and
    ``fixed`` the parameters held at a value (see ``IdentificationModel``). A dynamic law's model
    (:class:`~frictionid_core.model.dynamic_model.DynamicIdentificationModel`) is on every row of the
    metric observation (:attr:`Observation.metric`): its states run through, and its fit counts, the
    rows its metrics count.
    """
    plan = series if isinstance(series, FitPlan) else plan_fit(as_sources(series), as_system(system, joint_map))
    law = get_model(friction, asymmetric, elements)
    obs = observe_plan(plan, preprocessing, all_rows=law.is_dynamic)
    cls = IdentificationModel
    if law.is_dynamic:  # every row, those the metrics count: the recorded effort at the analysis instants
        from frictionid_core.model import DynamicIdentificationModel

        obs, cls = obs.full.metric, DynamicIdentificationModel
    return cls(obs, law, rigid_bounds=plan.system.parameter_bounds(plan.rows), bound_overrides=dict(bounds or {}),
               fixed=dict(fixed or {}))


def observe_sources(series: Sources, system: System, settings: Preprocessing | None = None) -> Observation:
    """The observation of one source, or of several (:func:`observe_plan` of their plan: every
    data joint fitted, nothing held)."""
    return observe_plan(plan_fit(as_sources(series), system), settings)


def observe_plan(plan: FitPlan, settings: Preprocessing | None = None, *, all_rows: bool = False) -> Observation:
    """The observation of the sources of ``plan``: each pre-processed alone (no filter runs across
    the seam between two recordings), then their rows stacked per joint (a joint a source does not
    fit has no rows there).

    One pre-processing describes the fit: the first source resolves the settings left to the
    data, its cut-off (one for every joint) the largest that any source's motion asks for; a joint
    the first source lacks takes its min speed from the first source that has it and the highest of
    its cut-offs. ``all_rows``: keep the fit rows with every row too (a dynamic law's model)."""
    system = plan.system
    requested = settings or system.preprocessing
    first, rest = plan.sources[0], plan.sources[1:]
    if rest and requested.cutoff_hz is None:
        fastest = max(cutoff_range(choose_preprocessing(resample_uniform(_preprocessed(sp, system)), requested)[0]
                                   .cutoff_hz)[1] for sp in plan.sources)  # one for every joint of every source
        requested = replace(requested, cutoff_hz=fastest)
    observations = [observe(first.series, system, on_source(requested, first.series), held=first.held,
                            rows=first.rows, all_rows=all_rows)]
    resolved = observations[0].preprocessing
    if requested is not (settings or system.preprocessing):
        observations[0].report["from_data"].insert(0, "cutoff_hz")
    speeds = dict(resolved.min_speed)
    given = requested.cutoff_hz if isinstance(requested.cutoff_hz, dict) else resolved.cutoff_hz
    for sp in rest:
        series = _preprocessed(sp, system)
        cutoffs = {j: given.get(j, max(given.values())) for j in sp.series.joints}
        missing = [j for j in series.joints if j not in speeds]
        if missing:
            own = choose_preprocessing(resample_uniform(series), replace(resolved, min_speed=None, cutoff_hz={
                j: cutoffs.get(j, max(cutoffs.values())) for j in series.joints}))[0].min_speed
            speeds.update((j, own[j]) for j in missing)
        observations.append(observe(sp.series, system, replace(resolved, min_speed=dict(speeds), cutoff_hz=cutoffs),
                                    held=sp.held, rows=sp.rows, all_rows=all_rows))
    if not rest:
        return observations[0]
    joints = list(dict.fromkeys(j for o in observations for j in o.joints))
    merged = replace(resolved, min_speed=speeds, cutoff_hz=_every_cutoff(observations))
    names = system.parameter_names(joints)
    stacked = [_on_rows(o, joints, names, system.per_joint, merged) for o in observations]
    out = concat_observations(stacked)
    out.report = _merged_report([o.report for o in observations])
    out.report["_source_samples"] = [o.n_samples for o in stacked]  # the rows of each source, in turn
    for o in (out.sampled, out.full, out.full and out.full.sampled):
        if o is not None:
            o.report = out.report
    return out


def on_source(settings: Preprocessing, series: JointSeries) -> Preprocessing:
    """``settings`` for one source: a per-joint cut-off or min speed restricted to its joints (a
    joint missing from them: the highest cut-off given)."""
    cut, speed = settings.cutoff_hz, settings.min_speed
    if isinstance(cut, dict):
        cut = {j: cut.get(j, max(cut.values())) for j in series.joints}
    if isinstance(speed, dict) and all(j in speed for j in series.joints):
        speed = {j: speed[j] for j in series.joints}
    return replace(settings, cutoff_hz=cut, min_speed=speed)


def _every_cutoff(observations: list[Observation]) -> float | dict[str, float]:
    """The cut-off of every joint of ``observations`` (the first source's, then each joint the
    first source lacks — one it holds still — from the first source that has it)."""
    first = observations[0].preprocessing.cutoff_hz
    if not isinstance(first, dict):
        return first
    out = dict(first)
    for o in observations[1:]:
        own = o.preprocessing.cutoff_hz
        for j, hz in (own.items() if isinstance(own, dict) else ((j, own) for j in o.joints)):
            out.setdefault(j, hz)
    return out


def _preprocessed(sp: SourcePlan, system: System) -> JointSeries:
    """The joints of a source that its pre-processing sees (all of a robot system's; the rows otherwise)."""
    return sp.series if system.robot is not None or sp.rows == list(sp.series.joints) else sp.series.select(sp.rows)


def _on_rows(obs: Observation, joints: list[str], names: list[str], per_joint: bool,
             settings: Preprocessing) -> Observation:
    """``obs`` on the row joints ``joints`` (its own among them) and rigid columns ``names`` (its
    own among them), with ``settings``: the rows of the joints it lacks are zero and unused."""
    nd, nj = obs.n_samples, len(joints)
    own = list(obs.rigid_names)
    if per_joint and len(obs.joints) == 1 and len(joints) > 1:
        own = [f"{obs.joints[0]}/{n}" for n in own]
    cols = [names.index(n) for n in own]
    y, used = np.zeros(nj * nd), np.zeros(nj * nd, dtype=bool)
    rigid, velocity = np.zeros((nj * nd, len(names))), np.zeros((nd, nj))
    columns = [{k: np.zeros(nd) for k in VELOCITY_COLUMNS} for _ in joints]
    moving = None if obs.moving is None else np.zeros(nj * nd, dtype=bool)
    travel = None if obs.path is None else (np.zeros((nd, nj)), np.zeros((nd, nj)))
    for j, joint in enumerate(obs.joints):
        k = joints.index(joint)
        src, dst = slice(j * nd, (j + 1) * nd), slice(k * nd, (k + 1) * nd)
        y[dst], used[dst], velocity[:, k], columns[k] = obs.y[src], obs.used[src], obs.velocity[:, j], obs.columns[j]
        rigid[dst, cols] = obs.rigid[src]
        if moving is not None:
            moving[dst] = obs.moving[src]
        if travel is not None:
            travel[0][:, k], travel[1][:, k] = obs.path[:, j], obs.shift[:, j]
    sampled, full = (None if o is None else _on_rows(o, joints, names, per_joint, settings)
                     for o in (obs.sampled, obs.full))
    return Observation(list(joints), y, rigid, list(names), velocity, columns, obs.t, settings, obs.report,
                       list(obs.notes), used, sampled, obs.coupling, obs.data_joints, obs.weight, full, moving,
                       *(travel or (None, None)))


def _merged_report(reports: list[dict]) -> dict:
    """The first source's report, each per-joint entry taken from the first source in which that
    joint moves (else the first that has it): a joint-wise sweep's still joints say nothing of
    their motion."""
    out = dict(reports[0])
    for key, value in reports[0].items():
        if isinstance(value, dict):
            merged = {}
            for joint in dict.fromkeys(j for r in reports for j in (r.get(key) or {})):
                having = [r for r in reports if joint in (r.get(key) or {})]
                moving = [r for r in having if joint in r.get("moving_joints", [])]
                merged[joint] = (moving or having)[0][key][joint]
            out[key] = merged
        elif key == "moving_joints":
            out[key] = list(dict.fromkeys(j for r in reports for j in r.get(key, [])))
    return out


def rule_series(series: JointSeries, system: System) -> JointSeries:
    """``series`` as the pre-processing rule sees it (:func:`frictionid_core.systems.observe`): on
    the joint side, its longest segment, on uniform stamps."""
    if system.drive is not None:
        series = system.drive.to_joint_side(series, system.joint_map)
    return resample_uniform(max(series.segments(), key=len))


def as_sources(series: Sources, window: tuple[float | None, float | None] | None = None) -> list[JointSeries]:
    """``series`` as a non-empty list of sources, each cut to ``window`` (start_s, end_s), s from
    its first sample (see :meth:`JointSeries.window`)."""
    sources = [series] if isinstance(series, JointSeries) else list(series)
    if not sources:
        raise FrictionIdError("no source given")
    return [s.window(*window) for s in sources] if window else sources


def model_metrics(model: IdentificationModel, x) -> dict:
    """:func:`~frictionid_core.model.metrics.observation_metrics` of the parameters ``x`` on the
    model's metric observation (the recorded effort at the analysis instants, predicted from
    the unfiltered columns there; or the model's own filtered rows under the EMPS protocol)."""
    on = metric_model(model)
    obs, predicted = on.obs, on.predict(x)
    if obs.moving is not None:  # a dynamic law's model: every row, the moving ones among them
        out = observation_metrics(obs, predicted, obs.moving)
        out["all_rows"] = all_rows_metrics(obs, predicted)
        return out
    out = observation_metrics(obs, predicted)
    if obs.full is not None:
        full = type(on)(obs.full, on.friction, on.offset, load_rigid=on.load_rigid)
        out["all_rows"] = all_rows_metrics(obs.full, full.predict(x))
    return out


def all_rows_relerr_pct(metrics: dict) -> float:
    """The relative error (%) on every row of a metrics block of :func:`model_metrics` (its own where it
    has no ``all_rows``: every row is a fit row)."""
    return float((metrics.get("all_rows") or metrics)["relerr_pct"])


def metric_model(model: IdentificationModel) -> IdentificationModel:
    """``model`` on its metric observation (:attr:`Observation.metric`: the recorded effort at the
    analysis instants with the unfiltered columns there, or its own rows under the EMPS protocol)."""
    obs = model.obs.metric
    return model if obs is model.obs else type(model)(obs, model.friction, model.offset, load_rigid=model.load_rigid)


def preprocessing_record(obs: Observation, metrics: dict, default: Preprocessing, requested: Preprocessing) -> dict:
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
