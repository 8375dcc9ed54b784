"""Systems by name: the fixed ones (one-joint, friction-only, TX40 joint 2) and the robot
systems built on request (``tx40``, ``urdf:PATH``; Pinocchio), each with an optional joint map."""

from __future__ import annotations

import functools
from pathlib import Path

from frictionid_core.errors import FrictionIdError
from frictionid_core.robots.model import load_urdf
from frictionid_core.robots.tx40 import build_tx40
from frictionid_core.systems.emps import ONE_JOINT
from frictionid_core.systems.friction_only import FRICTION_ONLY
from frictionid_core.systems.robot import robot_system
from frictionid_core.systems.system import System, parse_joint_map
from frictionid_core.systems.tx40_j2 import TX40_J2

FIXED_SYSTEMS: dict[str, System] = {s.name: s for s in (*ONE_JOINT, FRICTION_ONLY, TX40_J2)}
URDF_PREFIX = "urdf:"
# Every system name, for help texts and errors.
SYSTEM_NAMES = (*FIXED_SYSTEMS, "tx40", f"{URDF_PREFIX}PATH")
# How results written before the joint map had its own key carried it: "tx40?map=a=b,c=d".
_PACKED_MAP = "?map="


def get_system(name: str, joint_map: dict[str, str] | None = None) -> System:
    """The system ``name`` (one of SYSTEM_NAMES, ``urdf:PATH`` naming any fixed-base URDF file).

    ``joint_map`` {data joint: model joint} renames data joints for the robot systems. A robot
    system is built once per name, URDF modification time and joint map (its base parameters
    are computed once).
    """
    joint_map = dict(joint_map or {})
    if name in FIXED_SYSTEMS:
        if joint_map:
            raise FrictionIdError(f"system '{name}' takes no joint map; select joints with --joints")
        return FIXED_SYSTEMS[name]
    if name == "tx40":
        return _robot_system(name, None, tuple(joint_map.items()))
    if name.startswith(URDF_PREFIX):
        path = Path(name[len(URDF_PREFIX):]).expanduser()
        if not path.is_file():
            raise FrictionIdError(f"system '{name}': no such URDF file '{path}'")
        return _robot_system(name, path.stat().st_mtime_ns, tuple(joint_map.items()))
    raise FrictionIdError(f"unknown system '{name}'; choose one of {', '.join(SYSTEM_NAMES)}")


@functools.lru_cache(maxsize=16)
def _robot_system(name: str, stamp: int | None, joint_map: tuple[tuple[str, str], ...]) -> System:
    robot = build_tx40() if name == "tx40" else load_urdf(Path(name[len(URDF_PREFIX):]).expanduser())
    return robot_system(robot, name, dict(joint_map))


def as_system(system: str | System, joint_map: dict[str, str] | None = None) -> System:
    """``system`` itself, or the system of that name with ``joint_map``."""
    if isinstance(system, System):
        if joint_map:
            raise FrictionIdError(f"a joint map goes with a system name, not with the System '{system.name}' "
                                  "(it carries its own)")
        return system
    return get_system(system, joint_map)


def result_system(result: dict) -> System:
    """The system of an identification result (``Identification.to_dict()``): its ``system``
    and ``joint_map`` (older results pack the map into the name: ``tx40?map=a=b,c=d``)."""
    name, _, packed = str(result["system"]).partition(_PACKED_MAP)
    return get_system(name, result.get("joint_map") or parse_joint_map(packed))
