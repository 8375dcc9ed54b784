"""Inverse dynamic models ("systems"): rigid-body columns, joints and pre-processing presets.

* :mod:`~frictionid_core.systems.system` — the :class:`System` type and :func:`observe`.
* :mod:`~frictionid_core.systems.emps` — one-joint systems (``emps``).
* :mod:`~frictionid_core.systems.friction_only` — ``friction-only``.
* :mod:`~frictionid_core.systems.tx40_j2` — the thesis model of TX40 joint 2 (``tx40-j2``).
* :mod:`~frictionid_core.systems.robot` — full robots on Pinocchio (``tx40``, ``urdf:PATH``).
* :mod:`~frictionid_core.systems.registry` — systems by name (:func:`get_system`).
"""

from frictionid_core.systems.registry import SYSTEM_NAMES, as_system, get_system, result_system
from frictionid_core.systems.robot import nominal_parameters
from frictionid_core.systems.system import RobotInfo, System, observe, parse_joint_map

__all__ = ["SYSTEM_NAMES", "RobotInfo", "System", "as_system", "get_system", "nominal_parameters", "observe",
           "parse_joint_map", "result_system"]
