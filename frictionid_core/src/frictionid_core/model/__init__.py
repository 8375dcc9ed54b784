"""The identification model: data → observation → the torque rows of a parameter vector.

``IdentificationModel`` (inverse dynamic model + friction model on an :class:`Observation`, its
terms in :mod:`.terms`), ``DynamicIdentificationModel`` (a dynamic law's states along every row),
the observation (:mod:`.observation`), least squares and the bounded quadratic program
(:mod:`.least_squares`), load-dependent Coulomb columns (:mod:`.load_dependence`), what a parameter's
name says (:mod:`.parameter_names`) and the fit metrics (:mod:`.metrics`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("DynamicIdentificationModel",), "frictionid_core.model.dynamic_model"),
    **dict.fromkeys(("IdentificationModel",), "frictionid_core.model.identification_model"),
    **dict.fromkeys(("LOAD_NAME", "rigid_torque"), "frictionid_core.model.load_dependence"),
    **dict.fromkeys((
        "all_rows_metrics", "check_finite", "FINITE_METRICS", "fit_metrics", "improvement_pct",
        "metric_rows", "observation_metrics", "relerr_pct",
    ), "frictionid_core.model.metrics"),
    **dict.fromkeys((
        "build_observation", "concat_observations", "keep_all_rows", "Observation", "VELOCITY_COLUMNS",
    ), "frictionid_core.model.observation"),
    **dict.fromkeys(("parameter_kind",), "frictionid_core.model.parameter_names"),
}

__all__ = ["DynamicIdentificationModel", "FINITE_METRICS", "IdentificationModel", "LOAD_NAME", "Observation",
           "VELOCITY_COLUMNS", "all_rows_metrics", "build_observation", "check_finite", "concat_observations",
           "fit_metrics", "improvement_pct", "keep_all_rows", "metric_rows", "observation_metrics", "parameter_kind",
           "relerr_pct", "rigid_torque"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
