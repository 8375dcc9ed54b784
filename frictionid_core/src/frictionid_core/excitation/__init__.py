"""Excitation design: a Fourier trajectory optimised for the condition of the identification's
columns within the robot's limits (``frictionid excite``; :mod:`.design`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "add_dwell", "check_trajectory", "load_trajectory", "optimise_excitation", "robot_of",
    ), "frictionid_core.excitation.design"),
}

__all__ = ["add_dwell", "check_trajectory", "load_trajectory", "optimise_excitation", "robot_of"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
