"""Identification: a request (:class:`IdentifyRequest`) in, a result (:class:`IdentifyResult`) out.

    from frictionid_core.identification import IdentifyRequest, identify, validate

    result = identify(series, IdentifyRequest(system="emps", friction="coulomb"))
    metrics = validate(other_series, result)

One module per job: ``request`` (the request, its YAML file; ``settings``: its solver and
pre-processing parts; ``checks``: its field checks), ``result`` (the result and its JSON;
``result_fields``: the key-by-key checks of a result file),
``orchestration`` (:func:`identify`), ``effort_sign`` (an effort logged against its joint's axis),
``plan`` (what each source gives a fit),
``identifiability`` (what the data resolve), ``model_building`` (data → identification model,
metrics), ``solve`` (solver glue), ``linear_case`` (a law's Coulomb case: the bounds it grounds, the
held-back comparison, the fallback), ``dip_refit`` (the
friction-dip refit policy), ``uncertainty`` (σ, white and robust), ``plausibility`` (absurd fits,
links against the model, the known rigid body's report), ``reload`` (a result on other data:
:func:`model_from_result`, :func:`validate`). Other packages import the names of :data:`__all__`
from here; each is loaded on first use (PEP 562), so importing the request alone stays light.
"""

import importlib as _importlib

# Public names -> the module of this package that defines them.
_LAZY = {
    "IdentifyRequest": "request", "read_request": "request", "write_request": "request",
    "window_record": "request",
    "SolverOptions": "settings", "PreprocessingOverrides": "settings", "budget_field": "settings",
    "FieldError": "checks",
    "IdentifyResult": "result", "read_result": "result",
    "identify": "orchestration",
    "Sources": "model_building", "build_model": "model_building", "observe_sources": "model_building",
    "as_sources": "model_building", "model_metrics": "model_building", "metric_model": "model_building",
    "solve_model": "solve",
    "model_from_result": "reload", "validate": "reload", "validation_settings": "reload",
    "validation_metrics": "reload", "validation_record": "reload",
}

__all__ = ["FieldError", "IdentifyRequest", "IdentifyResult", "PreprocessingOverrides", "SolverOptions", "Sources",
           "as_sources", "budget_field", "build_model", "identify", "metric_model", "model_from_result",
           "model_metrics", "observe_sources", "read_request", "read_result", "solve_model", "validate",
           "validation_metrics", "validation_record", "validation_settings", "window_record", "write_request"]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
