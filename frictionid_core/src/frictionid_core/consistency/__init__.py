"""Physical consistency of rigid-body parameters: the check of identified base parameters and the
links' plausibility against a model (:mod:`.check`), the consistent fit, an SDP on the links'
pseudo-inertias (:mod:`.fit`; the model's links as its prior on what the data do not determine:
:mod:`.prior`), and a payload's consistent body (:mod:`.payload_sdp`).
cvxpy is imported when a program is solved.
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "body_report", "check_consistency", "link_plausibility", "plausibility_warnings", "projection",
        "PSEUDO_INERTIA_BASIS", "report_for_result", "standard_from_record", "standard_record",
    ), "frictionid_core.consistency.check"),
    **dict.fromkeys(("consistent_fit", "links_within_sigma"), "frictionid_core.consistency.fit"),
    **dict.fromkeys(("consistent_body",), "frictionid_core.consistency.payload_sdp"),
}

__all__ = ["PSEUDO_INERTIA_BASIS", "body_report", "check_consistency", "consistent_body", "consistent_fit",
           "link_plausibility", "links_within_sigma", "plausibility_warnings", "projection", "report_for_result",
           "standard_from_record", "standard_record"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
