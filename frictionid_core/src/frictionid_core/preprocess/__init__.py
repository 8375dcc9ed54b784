"""Signal preparation for inverse-dynamic identification (docs/reference.md#emps-idim-ls).

Zero-phase Butterworth on position, central differences for velocity and acceleration,
edge trimming, and parallel decimation (low-pass + keep 1 of n) of every observation column
and of the torque. Irregular stamps are first resampled onto a uniform grid.

One module per concern: ``settings`` (:class:`Preprocessing`, :class:`Prepared`, the rule's
constants), ``filters``, ``rule`` (the settings chosen from the data: read its docstring for the
rule), ``prepare`` (a log to prepared signals; :func:`preprocess`).
"""

from frictionid_core.preprocess.filters import (
    central_difference,
    decimate,
    decimation_indices,
    filtfilt,
    lowpass_position,
    near_reversals,
)
from frictionid_core.preprocess.prepare import (
    column_stride,
    dip_needs,
    prepare,
    preprocess,
    resample_uniform,
    reversal_acceleration,
    subsample,
    thinned_rows,
)
from frictionid_core.preprocess.rule import (
    choose_preprocessing,
    clean_acceleration_cutoff,
    cutoff_grid,
    cutoff_interval,
    differentiated_noise_var,
    motion_bandwidth,
    noise_density,
    prediction_cutoffs,
    recorded_velocity,
    risk_cutoffs,
    rule_decimation,
    rule_interval,
)
from frictionid_core.preprocess.settings import (
    ALIAS_BAND_PER_CUTOFF,
    ALIAS_BAND_SHARE,
    ANALYSIS_PER_CUTOFF,
    BANDWIDTH_SHARE,
    CUTOFF_GRID,
    CUTOFF_PER_BANDWIDTH,
    CUTOFFS_PER_DECADE,
    DIP_CUTOFF_FACTOR,
    DIP_FACTOR,
    DIP_WINDOW,
    FILTERS,
    JITTER_TOLERANCE,
    MAX_CUTOFF_SHARE,
    MAX_TRIM_SHARE,
    METRIC_EFFORTS,
    MIN_CUTOFF_BINS,
    MIN_SPEED_SHARE,
    MIN_SPEED_SIGMAS,
    MOVING_FACTOR,
    NOISE_BAND,
    PREDICTION_ROWS,
    PREDICTION_TOLERANCE,
    REVERSAL_PERIODS,
    SMOOTH_RATE_PER_CUTOFF,
    THIN_MARGIN,
    TRIM_PERIODS,
    Prepared,
    Preprocessing,
    TooFewSamples,
    cutoff_range,
    joint_cutoffs,
)

__all__ = [
    "ALIAS_BAND_PER_CUTOFF", "ALIAS_BAND_SHARE", "ANALYSIS_PER_CUTOFF", "BANDWIDTH_SHARE", "CUTOFFS_PER_DECADE",
    "CUTOFF_GRID", "CUTOFF_PER_BANDWIDTH", "DIP_CUTOFF_FACTOR", "DIP_FACTOR", "DIP_WINDOW", "FILTERS",
    "JITTER_TOLERANCE", "MAX_CUTOFF_SHARE", "MAX_TRIM_SHARE", "METRIC_EFFORTS", "MIN_CUTOFF_BINS",
    "MIN_SPEED_SHARE", "MIN_SPEED_SIGMAS", "MOVING_FACTOR", "NOISE_BAND", "PREDICTION_ROWS", "PREDICTION_TOLERANCE",
    "REVERSAL_PERIODS",
    "Prepared", "Preprocessing", "SMOOTH_RATE_PER_CUTOFF", "THIN_MARGIN", "TRIM_PERIODS", "TooFewSamples",
    "central_difference", "choose_preprocessing", "clean_acceleration_cutoff", "column_stride", "cutoff_grid",
    "cutoff_interval", "cutoff_range", "decimate", "decimation_indices", "differentiated_noise_var", "dip_needs",
    "filtfilt", "joint_cutoffs", "lowpass_position", "motion_bandwidth", "near_reversals", "noise_density",
    "prediction_cutoffs", "prepare", "preprocess", "recorded_velocity", "resample_uniform", "reversal_acceleration",
    "risk_cutoffs", "rule_decimation", "rule_interval", "subsample", "thinned_rows",
]
