"""A result reloaded on other data: its model (:func:`model_from_result`) with the pre-processing
of the result, the settings that follow the record (decimation, trims, min speed) chosen again
from these data (:func:`validation_settings`), and the cross-test (:func:`validate`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from frictionid_core.drive import result_drive
from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.friction import elements_of, get_model
from frictionid_core.identification.dynamic_rates import presliding_model
from frictionid_core.identification.effort_lag import with_result_effort_lag
from frictionid_core.identification.model_building import (
    Sources,
    as_sources,
    build_model,
    metric_model,
    model_metrics,
    rule_series,
)
from frictionid_core.identification.plan import Holds, plan_fit
from frictionid_core.identification.result import IdentifyResult
from frictionid_core.identification.settings import PreprocessingOverrides
from frictionid_core.model import LOAD_NAME, IdentificationModel, metric_rows
from frictionid_core.preprocess import Preprocessing
from frictionid_core.systems import as_system, result_system
from frictionid_core.timeseries import JointSeries

# The settings a result may have chosen from its data (its ``preprocessing.from_data``), and the
# one its identification found in its data (the stick phases: a property of the robot, kept).
DATA_SETTINGS = ("cutoff_hz", "decimate", "trim_start_s", "trim_end_s", "min_speed")
FOUND_SETTINGS = ("stick_speed",)
FIXED_WHY = "fixed in the identification"
FOUND_WHY = "found by the identification (the robot's stick phases)"
REVERSAL_WHY = "the identification's (rows near reversals left out)"
CHOSEN_WHY = "the identification's, chosen by what they predict"


def validation_settings(record: Mapping, series: JointSeries, overrides: PreprocessingOverrides | None = None,
                        *, dynamic: bool = False) -> tuple[Preprocessing, dict]:
    """The pre-processing to cross-test a result with, from its ``preprocessing`` block ``record``
    and the data ``series`` (the first source as the rule sees it: :func:`rule_series`): its
    settings, its cut-offs and min speed kept (fixed, or chosen by what they predict: the
    identification's choice is the one the data validated), the others it chose from its data (``from_data``:
    decimation, trims, min speed, which follow the record's rate, length and noise) chosen again
    from ``series``, and ``overrides`` (the user's) over all (a min speed given replaces the stick
    phases, as on ``identify``). A ``dynamic`` law's cut-offs chosen from the data by the rule alone
    (a result without a ``cross_validation`` choice, or whose fit from the rule's cut-offs won:
    ``dynamic_start``) are chosen again: the rule's, raised where the law predicts better, a choice
    :func:`model_from_result` makes again on these data; chosen by the folds, they are kept like a
    static law's (folds of a short validation log chose 10–100 Hz where the identification's 3–5 Hz
    validated at 4 %, they at 61 %).

    Returns the settings and which were ``rechosen``, ``kept`` (with ``kept_why``: {setting:
    reason}) and ``set``. A decimation chosen again drops the result's row thinning (set for its
    own dips and rates)."""
    settings = Preprocessing.from_dict(record, 1.0 / series.dt)
    given = (overrides or PreprocessingOverrides()).changes()
    from_data = record.get("from_data", [])
    chosen = [name for name in DATA_SETTINGS if name in from_data and name not in given]
    values: dict = dict.fromkeys(chosen)
    why = {name: FIXED_WHY for name in DATA_SETTINGS
           if name not in from_data and name not in given and getattr(settings, name) is not None}
    if "min_speed" in given:  # the user's slow rows replace those the identification left out
        values["stick_speed"] = None
        if "reversal_periods" not in given:
            values["reversal_periods"] = 0.0
    else:
        if settings.stick_speed:
            why["stick_speed"] = FOUND_WHY
        if settings.reversal_periods and "reversal_periods" not in given:
            why["reversal_periods"] = REVERSAL_WHY
    folds = record.get("cross_validation") or {}
    if "cutoff_hz" in chosen and (not dynamic or (folds.get("cutoff_hz")
                                                 and (folds.get("dynamic_start") or {}).get("taken") != "rule")):
        chosen.remove("cutoff_hz")
        values.pop("cutoff_hz")
        why["cutoff_hz"] = CHOSEN_WHY
    if "min_speed" in chosen and ((record.get("cross_validation") or {}).get("min_speed") or {}).get("min_speed"):
        chosen.remove("min_speed")  # below it the data showed friction leaving its law: a property of the robot
        values.pop("min_speed")
        why["min_speed"] = CHOSEN_WHY
    if "decimate" in chosen:
        values.update(thin=1, dip_scale=None)
    settings = replace(settings, **values, **given)
    return settings, {"rechosen": chosen, "kept": list(why), "kept_why": why, "set": sorted(given)}


def model_from_result(series: Sources, result: IdentifyResult | Mapping, *, system: str | None = None,
                      joint_map: dict[str, str] | None = None, joints: list[str] | None = None,
                      preprocessing: PreprocessingOverrides | None = None,
                      window: tuple[float | None, float | None] | None = None, payload=None
                      ) -> tuple[IdentificationModel, np.ndarray]:
    """The model of an identification ``result`` (an :class:`IdentifyResult` or its JSON, also one
    written by hand or by an earlier version) on ``series`` (one source or several) and its
    identified parameters (k,).

    System, joint map, joints, friction, drive, pre-processing and held joints come from the
    result, the settings it chose from its data chosen again from ``series`` where they can
    (:func:`validation_settings`; which: the observation report's ``rechosen``, ``kept``,
    ``kept_why``, ``set``; a dynamic law's cut-off that the rule alone chose chosen again, then raised
    where the result's law predicts these data better: :func:`~.dynamic_rates.presliding_model`); each argument given
    overrides its part (``preprocessing``: settings the user fixes; ``joint_map`` goes with
    ``system`` when both are given). ``window`` cuts ``series`` (s from the first sample); the
    result's own window is not reused. The joints the result held still are held again where it
    held them (the base parameters are those of that regressor; a logged column of such a joint is
    not used). ``payload``: a
    :class:`~frictionid_core.robots.payload_model.Payload` whose ten columns (``payload.<p>``) and values
    the model adds (:func:`~frictionid_core.robots.payload_model.with_payload`).
    """
    if isinstance(result, IdentifyResult):
        result = result.to_dict()
    try:
        if system is not None:
            sys_ = as_system(system, joint_map, result_drive(result))
        elif joint_map is not None:
            sys_ = as_system(result_system(result).name, joint_map, result_drive(result))
        else:
            sys_ = result_system(result)
        friction, asymmetric = result["friction"], bool(result["asymmetric"])
        elements = elements_of(friction, result["params"])  # a Maxwell-slip law's, from its k1 … kn
        joints = joints or result.get("joints")  # None (a hand-written file): the data's joints
        values = result["params"]
        asked = result.get("request") or {}
        held = dict(result.get("held_joints") or {})
    except KeyError as exc:
        raise FrictionIdError(f"parameter file lacks {exc}; expected the JSON written by "
                              "'frictionid identify'") from None
    sources = as_sources(series, window)  # on the recorded side: the system's drive converts them
    sources = with_result_effort_lag(sources, result.get("preprocessing"))
    holds = Holds({**(asked.get("hold") or {}), **held}, bool(asked.get("hold_missing")))
    plan = plan_fit(sources, sys_, list(joints) if joints else None, holds, structure=held, judge_effort=False)
    if result.get("preprocessing"):
        settings, which = validation_settings(result["preprocessing"], rule_series(plan.sources[0].series, sys_),
                                              preprocessing, dynamic=get_model(friction).is_dynamic)
    else:  # a hand-written file: the system's pre-processing, the user's settings over it
        settings, which = (preprocessing or PreprocessingOverrides()).apply(sys_.preprocessing), None
    if payload is not None:
        from frictionid_core.robots import with_payload

        plan = replace(plan, system=with_payload(plan.system, payload.link))
        values = {**values, **payload.parameters()}
    try:
        model = build_model(plan, plan.system, friction, asymmetric, settings, elements=elements)
    except InputError as exc:  # these data cannot choose (nothing moves): the result's own settings
        if which is None or not which["rechosen"] or "cannot be chosen from the data" not in str(exc):
            raise
        given = (preprocessing or PreprocessingOverrides()).changes()
        settings = replace(Preprocessing.from_dict(result["preprocessing"], 1.0 / sources[0].dt), **given)
        why = {**which["kept_why"], **dict.fromkeys(which["rechosen"], "these data cannot choose it")}
        which = {"rechosen": [], "kept": list(why), "kept_why": why, "set": which["set"]}
        model = build_model(plan, plan.system, friction, asymmetric, settings, elements=elements)
    if model.friction.is_dynamic and which is not None and "cutoff_hz" in which["rechosen"]:
        x = np.array([values.get(n, 0.0) for n in model.names], dtype=float)  # the law's cut-off on these data
        model = presliding_model(model, x, settings, lambda pre: build_model(plan, plan.system, friction, asymmetric,
                                                                            pre, elements=elements))
    if any(n.rsplit("/", 1)[-1] == LOAD_NAME for n in values):  # load-dependent: τ_rigid of its rigid body
        model = replace(model, load_rigid=np.array([values.get(n, 0.0) for n in model.obs.rigid_names], dtype=float))
    if which is not None:
        model.obs.report.update(which)
    missing = [n for n in model.names if n not in values]
    if missing:
        raise FrictionIdError(f"parameter file lacks parameter(s) {missing} of the model (it has {list(values)}); "
                              "expected the JSON written by 'frictionid identify' for this system, joints and friction")
    return model, np.array([values[n] for n in model.names], dtype=float)


def validate(series: Sources, result: IdentifyResult | Mapping, *, system: str | None = None,
             joint_map: dict[str, str] | None = None, joints: list[str] | None = None,
             preprocessing: PreprocessingOverrides | None = None,
             window: tuple[float | None, float | None] | None = None) -> dict[str, float]:
    """Cross-test: metrics of the identified parameters of ``result`` on ``series``, with the
    identification's system, joint map, joints, friction, drive and pre-processing; the other
    arguments override them as for :func:`model_from_result`."""
    model, x = model_from_result(series, result, system=system, joint_map=joint_map, joints=joints,
                                 preprocessing=preprocessing, window=window)
    return validation_metrics(model, x, [s.source for s in as_sources(series)])


def validation_metrics(model: IdentificationModel, x: np.ndarray, names: list[str]) -> dict[str, float]:
    """The cross-test metrics of parameters ``x`` on ``model`` (of :func:`model_from_result` on the
    sources ``names``); an error when no sample is left to test on."""
    obs = metric_model(model).obs
    if not (obs.used if obs.moving is None else obs.used & obs.moving).any():  # a dynamic law's: its moving rows
        raise FrictionIdError(f"{', '.join(names)}: no sample left to cross-test on (every one slower than the min "
                              "speed of the pre-processing, or trimmed away); --cutoff and --min-speed set them")
    return model_metrics(model, x)


def validation_residuals(model: IdentificationModel, x: np.ndarray) -> dict:
    """The rows :func:`validation_metrics` compares, instant by instant: ``t`` (Nd,) s on each
    source's own clock, ``source`` (Nd,) the index of the source of each instant, ``joints``,
    ``effort`` and ``predicted`` (J, Nd) the effort the metrics compare (recorded, at the analysis
    instants; the EMPS protocol's filtered one) and the prediction (joint torques, N·m or N),
    ``used`` (J, Nd) the rows the metrics count (slow rows, reversals and trims out; a dynamic
    law's: its moving rows)."""
    on = metric_model(model)
    obs = on.obs
    joints, y, y_hat, used = metric_rows(obs, on.predict(x), obs.moving)
    nd = obs.n_samples
    sizes = obs.report.get("_source_samples") or [nd]
    return {"t": obs.t, "source": np.repeat(np.arange(len(sizes)), sizes), "joints": joints,
            "effort": y.reshape(len(joints), nd), "predicted": y_hat.reshape(len(joints), nd),
            "used": used.reshape(len(joints), nd)}


def validation_record(model: IdentificationModel) -> dict:
    """The ``preprocessing`` block of a cross-test of ``model`` (of :func:`model_from_result`): the
    settings used, what the data said, and which settings were re-chosen, kept and set."""
    obs = model.obs
    record = obs.preprocessing.to_dict()
    record.update({k: v for k, v in obs.report.items() if not k.startswith("_")})
    return record
