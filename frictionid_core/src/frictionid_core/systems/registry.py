"""Systems by name: the fixed ones (one-joint, friction-only, TX40 joint 2) and the robot
systems built on request (``tx40``, ``urdf:PATH``; Pinocchio), each with an optional joint map."""

from __future__ import annotations

import functools
from dataclasses import replace
from pathlib import Path

from frictionid_core.drive import Drive, result_drive
from frictionid_core.errors import FrictionIdError
from frictionid_core.robots import build_tx40, load_urdf
from frictionid_core.systems.emps import JOINT_GRAVITY, ONE_JOINT
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


def get_system(name: str, joint_map: dict[str, str] | None = None, drive: Drive | None = None,
               gravity: bool = False) -> System:
    """The system ``name`` (one of SYSTEM_NAMES, ``urdf:PATH`` naming any fixed-base URDF file);
    ``gravity``: ``joint`` with a gravity term per joint (``g_sin``, ``g_cos``).

    ``joint_map`` {data joint: model joint} renames data joints for the robot systems; ``drive``
    (:mod:`frictionid_core.drive.transmission`) converts the log to the joint side, and with friction on the
    motors makes the motors the fit rows. A robot system is built once per name, URDF
    modification time, joint map and motor-side drive (its base parameters are computed once).
    """
    joint_map = dict(joint_map or {})
    if gravity:
        if name != JOINT_GRAVITY.name:
            raise FrictionIdError(f"system '{name}' takes no gravity term (only '{JOINT_GRAVITY.name}' does)")
        fixed_system = JOINT_GRAVITY
    else:
        fixed_system = FIXED_SYSTEMS.get(name)
    if fixed_system is not None:
        if joint_map:
            raise FrictionIdError(f"system '{name}' takes no joint map; select joints with --joints")
        return with_drive(fixed_system, drive)
    if name == "tx40":
        stamp = None
    elif name.startswith(URDF_PREFIX):
        path = Path(name[len(URDF_PREFIX):]).expanduser()
        if not path.is_file():
            raise FrictionIdError(f"system '{name}': no such URDF file '{path}'")
        stamp = path.stat().st_mtime_ns
    else:
        raise FrictionIdError(f"unknown system '{name}'; choose one of {', '.join(SYSTEM_NAMES)}")
    motor_drive = drive if drive is not None and drive.friction_on == "motor" else None
    return with_drive(_robot_system(name, stamp, tuple(joint_map.items()), motor_drive), drive)


@functools.lru_cache(maxsize=16)
def _robot_system(name: str, stamp: int | None, joint_map: tuple[tuple[str, str], ...],
                  motor_drive: Drive | None) -> System:
    robot = build_tx40() if name == "tx40" else load_urdf(Path(name[len(URDF_PREFIX):]).expanduser())
    return robot_system(robot, name, dict(joint_map), drive=motor_drive)


def with_drive(system: System, drive: Drive | None) -> System:
    """``system`` reading its logs through ``drive`` (None: as they are).

    A robot system whose rows are not yet the motors of a friction-on-motor drive must be built
    with it (:func:`get_system`); the other systems have one joint or no rigid-body columns, so
    their columns hold in the motor rows as they are (C = 1 for one joint)."""
    if drive is None or drive == system.drive:
        return system
    motor_drive = drive if drive.friction_on == "motor" else None
    if system.robot is not None:
        built = system.robot.rows.drive if system.robot.rows is not None else None
        if built != motor_drive:
            raise FrictionIdError(f"system '{system.name}': its rows were built for another drive; pass the drive "
                                  "with the system's name (get_system(name, drive=…))")
    elif motor_drive is not None and system.rigid_names and system.joints != 1:
        raise FrictionIdError(f"system '{system.name}' cannot put friction on coupled motors "
                              "(its rigid-body columns are joint torques)")
    return replace(system, drive=drive)


def as_system(system: str | System, joint_map: dict[str, str] | None = None, drive: Drive | None = None,
              gravity: bool = False) -> System:
    """``system`` itself (reading its logs through ``drive`` when given), or the system of that
    name with ``joint_map``, ``drive`` and ``gravity`` (see :func:`get_system`)."""
    if isinstance(system, System):
        if joint_map:
            raise FrictionIdError(f"a joint map goes with a system name, not with the System '{system.name}' "
                                  "(it carries its own)")
        return with_drive(system, drive)
    return get_system(system, joint_map, drive, gravity)


def result_system(result: dict) -> System:
    """The system of an identification result (``IdentifyResult.to_dict()``): its ``system``,
    ``joint_map`` (older results pack the map into the name: ``tx40?map=a=b,c=d``), ``drive`` and
    its gravity terms (``g_sin`` parameters)."""
    name, _, packed = str(result["system"]).partition(_PACKED_MAP)
    gravity = any(str(p).rsplit("/", 1)[-1] == "g_sin" for p in result.get("params") or {})
    return get_system(name, result.get("joint_map") or parse_joint_map(packed), result_drive(result), gravity)
