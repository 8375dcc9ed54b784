"""Synthetic logs of a robot with known truth: Pinocchio torques along a trajectory, friction of any
law, noise (``frictionid synth``; :mod:`.robot_logs`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "expected_parameters", "read_friction_params", "synthesize",
    ), "frictionid_core.synthetic.robot_logs"),
}

__all__ = ["expected_parameters", "read_friction_params", "synthesize"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
