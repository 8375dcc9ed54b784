"""The identification model of data: sources → observation → :class:`IdentificationModel`, and its metrics."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.friction import get_model
from frictionid_core.identification_model import IdentificationModel
from frictionid_core.metrics import observation_metrics
from frictionid_core.observation import Observation, concat_observations
from frictionid_core.preprocess import Preprocessing
from frictionid_core.systems import System, as_system, observe
from frictionid_core.timeseries import JointSeries

# One source, or several fitted together.
Sources = JointSeries | Sequence[JointSeries]


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
                             f"{list(first.joints)}; the sources of one fit need the same joints "
                             "(select with --joints)")
    obs = observe(first, system, settings)
    return concat_observations([obs] + [observe(s, system, obs.preprocessing) for s in sources[1:]])


def as_sources(series: Sources, window: tuple[float | None, float | None] | None = None) -> list[JointSeries]:
    """``series`` as a non-empty list of sources, each cut to ``window`` (start_s, end_s), s from
    its first sample (see :meth:`JointSeries.window`)."""
    sources = [series] if isinstance(series, JointSeries) else list(series)
    if not sources:
        raise FrictionIdError("no source given")
    return [s.window(*window) for s in sources] if window else sources


def model_metrics(model: IdentificationModel, x) -> dict:
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
