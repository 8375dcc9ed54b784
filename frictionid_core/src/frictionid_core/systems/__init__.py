"""Inverse dynamic models ("systems"): rigid-body columns, joints and pre-processing presets.

* :mod:`.system` — the :class:`System` type and :func:`observe`.
* :mod:`.emps` — one-joint systems (``emps``, ``joint``).
* :mod:`.friction_only` — ``friction-only``.
* :mod:`.tx40_j2` — the thesis model of TX40 joint 2 (``tx40-j2``).
* :mod:`.robot` — full robots on Pinocchio (``tx40``, ``urdf:PATH``).
* :mod:`.registry` — systems by name (:func:`get_system`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "as_system", "FIXED_SYSTEMS", "get_system", "result_system", "SYSTEM_NAMES", "URDF_PREFIX",
    ), "frictionid_core.systems.registry"),
    **dict.fromkeys((
        "known_rigid_body", "KnownRigidBody", "LINK_TORQUE", "nominal_parameters", "restricted_system",
    ), "frictionid_core.systems.robot"),
    **dict.fromkeys((
        "burn_in_rows", "exclude_rows", "observe", "parse_joint_map", "reversal_rows", "RobotInfo", "System",
    ), "frictionid_core.systems.system"),
}

__all__ = ["FIXED_SYSTEMS", "KnownRigidBody", "LINK_TORQUE", "RobotInfo", "SYSTEM_NAMES", "System", "URDF_PREFIX",
           "as_system", "burn_in_rows", "exclude_rows", "get_system", "known_rigid_body", "nominal_parameters",
           "observe", "parse_joint_map", "restricted_system", "result_system", "reversal_rows"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
