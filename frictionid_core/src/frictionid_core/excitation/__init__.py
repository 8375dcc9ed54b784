"""Excitation design (``frictionid excite``): a Fourier trajectory optimised for the condition of the
identification's columns (:mod:`.design`), within every limit of the robot — position, velocity,
acceleration, effort (:mod:`.limits`) and the clearance between its links (:mod:`.collision`, coal
on Pinocchio's geometry model) — by a constrained optimisation (:mod:`.within_limits`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("DEFAULT_CLEARANCE", "load_collision_model"), "frictionid_core.excitation.collision"),
    **dict.fromkeys((
        "add_dwell", "check_trajectory", "load_trajectory", "optimise_excitation", "robot_of",
    ), "frictionid_core.excitation.design"),
    **dict.fromkeys((
        "result_friction", "robot_limits", "verify", "violation_text",
    ), "frictionid_core.excitation.limits"),
    **dict.fromkeys(("design_excitation",), "frictionid_core.excitation.within_limits"),
}

__all__ = ["DEFAULT_CLEARANCE", "add_dwell", "check_trajectory", "design_excitation", "load_collision_model",
           "load_trajectory", "optimise_excitation", "result_friction", "robot_limits", "robot_of", "verify",
           "violation_text"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
