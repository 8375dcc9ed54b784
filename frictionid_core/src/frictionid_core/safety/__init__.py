"""The safety screen of every parameter set that can reach a robot: the node's identification
results, ``~/load``, ``results_file`` and online candidates, and ``frictionid export --yaml`` pass
:func:`screen_parameters` (or :func:`result_refusals`) against each joint's :class:`Limit`
(:func:`robot_limits`, :func:`data_limits`; :mod:`.screen`); a payload passes :func:`payload_refusals`
(:mod:`.payload_screen`); a motion is checked against the robot's limits before it is commanded
(:func:`screen_motion`, :mod:`.motion_screen`); an online re-identification replaces the active set
only through the gate (:func:`review`: screened and better on held-back data; :mod:`.gate`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("Decision", "review"), "frictionid_core.safety.gate"),
    **dict.fromkeys(("screen_motion",), "frictionid_core.safety.motion_screen"),
    **dict.fromkeys(("payload_refusals",), "frictionid_core.safety.payload_screen"),
    **dict.fromkeys((
        "data_limits", "DATA_MARGIN", "effort_sign_refusals", "explicit_bounds", "Limit", "result_refusals",
        "robot_limits", "screen_parameters",
    ), "frictionid_core.safety.screen"),
}

__all__ = ["DATA_MARGIN", "Decision", "Limit", "data_limits", "effort_sign_refusals", "explicit_bounds",
           "payload_refusals", "result_refusals", "review", "robot_limits", "screen_motion", "screen_parameters"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
