"""Signal preparation for inverse-dynamic identification (docs/reference.md#emps-idim-ls).

Zero-phase Butterworth on position, central differences for velocity and acceleration,
edge trimming, and parallel decimation (low-pass + keep 1 of n) of every observation column
and of the torque. Irregular stamps are first resampled onto a uniform grid.

One module per concern: ``settings`` (:class:`Preprocessing`, :class:`Prepared`, the rule's
constants), ``filters``, ``rule`` (the settings chosen from the data: read its docstring for the
rule), ``preparation`` (a log to prepared signals; :func:`preprocess`), ``lag`` (a lag of the
logged velocity and effort behind the position), ``travel`` (the travel a dynamic friction law's
states follow).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "brief_runs", "central_difference", "decimate", "decimation_indices", "lowpass_position",
        "near_reversals", "window_means",
    ), "frictionid_core.preprocess.filters"),
    **dict.fromkeys(("effort_lag_candidate", "lag_record", "remove_channel_lag", "shift_effort"),
                    "frictionid_core.preprocess.lag"),
    **dict.fromkeys((
        "column_stride", "dip_needs", "prepare", "preprocess", "resample_uniform", "subsample", "thinned_rows",
    ), "frictionid_core.preprocess.preparation"),
    **dict.fromkeys((
        "choose_preprocessing", "noise_density", "rule_decimation",
    ), "frictionid_core.preprocess.rule"),
    **dict.fromkeys(("PLAY_SIGMAS", "play", "travel_noise", "travel_rows"),
                    "frictionid_core.preprocess.travel"),
    **dict.fromkeys((
        "BRIEF_PERIODS", "cutoff_range", "CUTOFFS_PER_DECADE", "DIP_WINDOW", "MAX_CUTOFF_SHARE", "MIN_SPEED_SHARE",
        "MIN_SPEED_SIGMAS", "MOVING_FACTOR", "PREDICTION_TOLERANCE", "Prepared", "Preprocessing",
        "QDD_NOISE_SHARE_LIMIT", "REVERSAL_PERIODS", "TooFewSamples", "TRIM_PERIODS", "VELOCITY_SOURCES",
    ), "frictionid_core.preprocess.settings"),
}

__all__ = ["BRIEF_PERIODS", "CUTOFFS_PER_DECADE", "DIP_WINDOW", "MAX_CUTOFF_SHARE", "MIN_SPEED_SHARE",
           "MIN_SPEED_SIGMAS", "MOVING_FACTOR", "PLAY_SIGMAS", "PREDICTION_TOLERANCE", "Prepared", "Preprocessing",
           "QDD_NOISE_SHARE_LIMIT", "REVERSAL_PERIODS", "TRIM_PERIODS", "TooFewSamples", "VELOCITY_SOURCES",
           "brief_runs", "central_difference", "choose_preprocessing", "column_stride", "cutoff_range", "decimate",
           "decimation_indices", "dip_needs", "effort_lag_candidate", "lag_record", "lowpass_position",
           "near_reversals", "noise_density", "play", "prepare", "preprocess", "remove_channel_lag", "resample_uniform",
           "rule_decimation", "shift_effort", "subsample", "thinned_rows", "travel_noise", "travel_rows",
           "window_means"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
