"""Identification: a request (:class:`IdentifyRequest`) in, a result (:class:`IdentifyResult`) out.

    from frictionid_core.identification import IdentifyRequest, identify, validate

    result = identify(series, IdentifyRequest(system="emps", friction="coulomb"))
    metrics = validate(other_series, result)

One module per job: ``at_bound`` (parameters that end at a bound: not identified values),
``request`` (the request, its YAML file; ``settings``: its solver and
pre-processing parts; ``checks``: its field checks), ``result`` (the result and its JSON;
``result_fields``: the key-by-key checks of a result file),
``orchestration`` (:func:`identify`), ``effort_sign`` (an effort logged against its joint's axis),
``plan`` (what each source gives a fit), ``joint_signals`` (a joint's motion that excites its columns,
its effort's information),
``identifiability`` (what the data resolve), ``payload_identification`` and ``payload_fit`` (a payload on a
link from a loaded log and a base result), ``model_building`` (data → identification model,
metrics), ``solve`` (solver glue), ``linear_case`` (a law's Coulomb case: the bounds it grounds, the
held-back comparison, the fallback), ``dip_refit`` (the
friction-dip refit policy), ``uncertainty`` (σ, white and robust), ``plausibility`` (absurd fits,
links against the model, the known rigid body's report), ``validation`` (a result on other data:
:func:`model_from_result`, :func:`validate`). Other packages import the names of :data:`__all__`
from here; each is loaded on first use (PEP 562), so importing the request alone stays light.
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("nonlinear_at_bound",), "frictionid_core.identification.at_bound"),
    **dict.fromkeys(("FieldError",), "frictionid_core.identification.checks"),
    **dict.fromkeys((
        "as_sources", "build_model", "metric_model", "model_metrics", "observe_sources", "Sources",
    ), "frictionid_core.identification.model_building"),
    **dict.fromkeys(("identify",), "frictionid_core.identification.orchestration"),
    **dict.fromkeys((
        "identify_payload", "loaded_result", "payload_of", "PayloadRequest", "PayloadResult", "read_payload",
    ), "frictionid_core.identification.payload_identification"),
    **dict.fromkeys(("check_metrics",), "frictionid_core.identification.plausibility"),
    **dict.fromkeys((
        "IdentifyRequest", "read_request", "window_record", "write_request",
    ), "frictionid_core.identification.request"),
    **dict.fromkeys(("IdentifyResult", "read_result"), "frictionid_core.identification.result"),
    **dict.fromkeys((
        "budget_field", "PreprocessingOverrides", "SolverOptions",
    ), "frictionid_core.identification.settings"),
    **dict.fromkeys(("solve_model",), "frictionid_core.identification.solve"),
    **dict.fromkeys((
        "model_from_result", "validate", "validation_metrics", "validation_record", "validation_residuals",
        "validation_settings",
    ), "frictionid_core.identification.validation"),
}

__all__ = ["FieldError", "IdentifyRequest", "IdentifyResult", "PayloadRequest", "PayloadResult",
           "PreprocessingOverrides", "SolverOptions", "Sources", "as_sources", "budget_field", "build_model",
           "check_metrics", "identify", "identify_payload", "loaded_result", "metric_model", "model_from_result",
           "model_metrics", "nonlinear_at_bound", "observe_sources", "payload_of", "read_payload", "read_request",
           "read_result", "solve_model", "validate", "validation_metrics", "validation_record", "validation_residuals",
           "validation_settings", "window_record", "write_request"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
