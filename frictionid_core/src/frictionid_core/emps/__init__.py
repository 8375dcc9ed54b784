"""The EMPS benchmark (docs/reference.md#emps): its closed-loop simulator (:mod:`.simulation`), the
output-error fit (:mod:`.output_error`), grey + black-box ensembles (:mod:`.ensemble`), the
statistical study of optimisers (:mod:`.study`) and its HTML report (:mod:`.report`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("CLOCKS",), "frictionid_core.emps.clocks"),
    **dict.fromkeys(("grey_black_ensemble",), "frictionid_core.emps.ensemble"),
    **dict.fromkeys(("identify_output_error",), "frictionid_core.emps.output_error"),
    **dict.fromkeys(("build_report",), "frictionid_core.emps.report"),
    **dict.fromkeys((
        "EmpsSimulator", "load_emps", "METRIC_KEYS", "simulate_identification",
    ), "frictionid_core.emps.simulation"),
    **dict.fromkeys(("ALGORITHMS", "analyse", "format_summary", "plan", "run_study"), "frictionid_core.emps.study"),
}

__all__ = ["ALGORITHMS", "CLOCKS", "EmpsSimulator", "METRIC_KEYS", "analyse", "build_report", "format_summary",
           "grey_black_ensemble", "identify_output_error", "load_emps", "plan", "run_study", "simulate_identification"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
