"""Results compared: identified against ground-truth parameters and the noise floor, fits side by
side, payloads (``frictionid compare``; :mod:`.truth`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "check_result", "compare", "compare_fits", "compare_payloads", "fit_labels", "flatten", "noise_floor",
        "RESOLVE_TOLERANCE_PCT", "select_truth", "Z95",
    ), "frictionid_core.compare.truth"),
}

__all__ = ["RESOLVE_TOLERANCE_PCT", "Z95", "check_result", "compare", "compare_fits", "compare_payloads", "fit_labels",
           "flatten", "noise_floor", "select_truth"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
