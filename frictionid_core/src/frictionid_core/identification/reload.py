"""A result reloaded on other data: its model (:func:`model_from_result`) and the cross-test
(:func:`validate`)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from frictionid_core.drive import result_drive
from frictionid_core.errors import FrictionIdError
from frictionid_core.identification.model_building import Sources, as_sources, build_model, metric_model, model_metrics
from frictionid_core.identification.plan import Holds, plan_fit
from frictionid_core.identification.result import IdentifyResult
from frictionid_core.identification_model import IdentificationModel
from frictionid_core.preprocess import Preprocessing
from frictionid_core.systems import as_system, result_system


def model_from_result(series: Sources, result: IdentifyResult | Mapping, *, system: str | None = None,
                      joint_map: dict[str, str] | None = None, joints: list[str] | None = None,
                      preprocessing: Preprocessing | None = None,
                      window: tuple[float | None, float | None] | None = None
                      ) -> tuple[IdentificationModel, np.ndarray]:
    """The model of an identification ``result`` (an :class:`IdentifyResult` or its JSON, also one
    written by hand or by an earlier version) on ``series`` (one source or several) and its
    identified parameters (k,).

    System, joint map, joints, friction, drive, pre-processing and held joints come from the
    result; each argument given overrides its part (``joint_map`` goes with ``system`` when both
    are given). ``window`` cuts ``series`` (s from the first sample); the result's own window is
    not reused. The joints the result held still are held again where it held them (the base
    parameters are those of that regressor; a logged column of such a joint is not used).
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
        asked = result.get("request") or {}
        held = dict(result.get("held_joints") or {})
    except KeyError as exc:
        raise FrictionIdError(f"parameter file lacks {exc}; expected the JSON written by "
                              "'frictionid identify'") from None
    sources = as_sources(series, window)  # on the recorded side: the system's drive converts them
    if preprocessing is None and result.get("preprocessing"):
        preprocessing = Preprocessing.from_dict(result["preprocessing"], 1.0 / sources[0].dt)
    holds = Holds({**(asked.get("hold") or {}), **held}, bool(asked.get("hold_missing")))
    plan = plan_fit(sources, sys_, list(joints) if joints else None, holds, structure=held, judge_effort=False)
    model = build_model(plan, plan.system, friction, asymmetric, preprocessing)
    missing = [n for n in model.names if n not in values]
    if missing:
        raise FrictionIdError(f"parameter file lacks parameter(s) {missing} of the model (it has {list(values)}); "
                              "expected the JSON written by 'frictionid identify' for this system, joints and friction")
    return model, np.array([values[n] for n in model.names], dtype=float)


def validate(series: Sources, result: IdentifyResult | Mapping, *, system: str | None = None,
             joint_map: dict[str, str] | None = None, joints: list[str] | None = None,
             preprocessing: Preprocessing | None = None,
             window: tuple[float | None, float | None] | None = None) -> dict[str, float]:
    """Cross-test: metrics of the identified parameters of ``result`` on ``series``, with the
    identification's system, joint map, joints, friction, drive and pre-processing; the other
    arguments override them as for :func:`model_from_result`."""
    model, x = model_from_result(series, result, system=system, joint_map=joint_map, joints=joints,
                                 preprocessing=preprocessing, window=window)
    if not metric_model(model).obs.used.any():
        names = ", ".join(s.source for s in as_sources(series))
        raise FrictionIdError(f"{names}: no sample left to cross-test on (every one slower than the min speed of the "
                              "pre-processing, or trimmed away)")
    return model_metrics(model, x)
