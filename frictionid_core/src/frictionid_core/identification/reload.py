"""A result reloaded on other data: its model (:func:`model_from_result`) with the pre-processing
settings the result chose from its data chosen again from these (:func:`validation_settings`), and
the cross-test (:func:`validate`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from frictionid_core.drive import result_drive
from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.identification.model import Sources, as_sources, build_model, model_metrics
from frictionid_core.identification.result import IdentifyResult
from frictionid_core.identification.settings import PreprocessingOverrides
from frictionid_core.identification_model import IdentificationModel
from frictionid_core.preprocess import Preprocessing
from frictionid_core.systems import as_system, result_system

# The settings a result may have chosen from its data (its ``preprocessing.from_data``), and the
# one its identification found in its data (the stick phases: a property of the robot, kept).
DATA_SETTINGS = ("cutoff_hz", "decimate", "trim_start_s", "trim_end_s", "min_speed")
FOUND_SETTINGS = ("stick_speed",)


def validation_settings(record: Mapping, rate_hz: float, overrides: PreprocessingOverrides | None = None
                        ) -> tuple[Preprocessing, dict[str, list[str]]]:
    """The pre-processing to cross-test a result with, from its ``preprocessing`` block ``record``
    (``rate_hz``: the data's, for results that held trims in samples): its settings, those it chose
    from its data (``from_data``) left to be chosen from the new data, ``overrides`` (the user's)
    over both; and which settings were ``rechosen``, ``kept`` (the data-dependent ones the result
    fixed or found) and ``set``.

    A cut-off chosen for some joints only (``cutoff_from_data``) keeps the others'; a decimation
    chosen again drops the result's row thinning (set for its own dips and rates)."""
    settings = Preprocessing.from_dict(record, rate_hz)
    given = (overrides or PreprocessingOverrides()).changes()
    chosen = [name for name in DATA_SETTINGS if name in record.get("from_data", []) and name not in given]
    values = dict.fromkeys(chosen)
    if "cutoff_hz" in chosen and isinstance(settings.cutoff_hz, dict) and record.get("cutoff_from_data") is not None:
        kept = {j: v for j, v in settings.cutoff_hz.items() if j not in record["cutoff_from_data"]}
        values["cutoff_hz"] = kept or None
    if "decimate" in chosen:
        values.update(thin=1, dip_scale=None)
    settings = replace(settings, **values, **given)
    kept = [name for name in DATA_SETTINGS + FOUND_SETTINGS
            if name not in chosen and name not in given and getattr(settings, name) is not None]
    return settings, {"rechosen": chosen, "kept": kept, "set": sorted(given)}


def model_from_result(series: Sources, result: IdentifyResult | Mapping, *, system: str | None = None,
                      joint_map: dict[str, str] | None = None, joints: list[str] | None = None,
                      preprocessing: PreprocessingOverrides | None = None,
                      window: tuple[float | None, float | None] | None = None
                      ) -> tuple[IdentificationModel, np.ndarray]:
    """The model of an identification ``result`` (an :class:`IdentifyResult` or its JSON, also one
    written by hand or by an earlier version) on ``series`` (one source or several) and its
    identified parameters (k,).

    System, joint map, joints, friction, drive and pre-processing come from the result, the
    settings it chose from its data chosen again from ``series`` (:func:`validation_settings`;
    which: the observation report's ``rechosen``, ``kept``, ``set``); each argument given overrides
    its part (``preprocessing``: settings the user fixes; ``joint_map`` goes with ``system`` when
    both are given). ``window`` cuts ``series`` (s from the first sample); the result's own window
    is not reused.
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
        joints = joints or result.get("joints")  # None (a hand-written file): the data's joints
        values = result["params"]
    except KeyError as exc:
        raise FrictionIdError(f"parameter file lacks {exc}; expected the JSON written by "
                              "'frictionid identify'") from None
    sources = as_sources(series, window)  # on the recorded side: the system's drive converts them
    if result.get("preprocessing"):
        settings, which = validation_settings(result["preprocessing"], 1.0 / sources[0].dt, preprocessing)
    else:  # a hand-written file: the system's pre-processing, the user's settings over it
        settings, which = (preprocessing or PreprocessingOverrides()).apply(sys_.preprocessing), None
    if joints:
        sources = [s.select(list(joints)) for s in sources]
    try:
        model = build_model(sources, sys_, friction, asymmetric, settings)
    except InputError as exc:  # these data cannot choose (nothing moves): the result's own settings
        if which is None or not which["rechosen"] or "cannot be chosen from the data" not in str(exc):
            raise
        given = (preprocessing or PreprocessingOverrides()).changes()
        settings = replace(Preprocessing.from_dict(result["preprocessing"], 1.0 / sources[0].dt), **given)
        which = {"rechosen": [], "kept": which["kept"] + which["rechosen"], "set": which["set"]}
        model = build_model(sources, sys_, friction, asymmetric, settings)
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
    return model_metrics(model, x)


def validation_record(model: IdentificationModel) -> dict:
    """The ``preprocessing`` block of a cross-test of ``model`` (of :func:`model_from_result`): the
    settings used, what the data said, and which settings were re-chosen, kept and set."""
    obs = model.obs
    record = obs.preprocessing.to_dict()
    record.update({k: v for k, v in obs.report.items() if not k.startswith("_")})
    return record
