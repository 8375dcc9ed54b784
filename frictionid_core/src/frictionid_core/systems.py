"""Inverse dynamic models ("systems"): rigid-body columns and pre-processing presets.

A system turns pre-processed signals into the full-rate rigid-body columns of the
observation matrix and says how its data are pre-processed by default.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from frictionid_core.errors import FrictionIdError, InputError
from frictionid_core.observation import Observation, build_observation
from frictionid_core.preprocess import Prepared, Preprocessing, prepare
from frictionid_core.timeseries import JointSeries


@dataclass(frozen=True)
class System:
    """An inverse dynamic model without its friction.

    Attributes:
        name: system id (``emps``, ``friction-only``, …).
        rigid_names: rigid-body parameter names.
        rigid_bounds: default search bounds of those parameters.
        preprocessing: default pre-processing.
        columns: prepared signals + joint names → rigid columns (J·N, R), joint-major rows.
        joints: joint count the system needs (None: any).
        sample_period: the nominal sample period of the system's protocol, s (None: from stamps).
        check_joints: raises InputError when the data's joint names do not fit the system
            (called before any pre-processing; None: no check).
        info: system-specific facts (a robot system's model, base parameters, joint map).
        min_speed: rows whose (decimated) joint speed |q̇| is below this are left out of the
            identification (zeroed: torque, every column and the velocity), because the sign of
            a noisy velocity near a reversal is unreliable and one wrong sign is a 2·Fs outlier;
            None keeps every row.
    """

    name: str
    rigid_names: tuple[str, ...]
    rigid_bounds: dict[str, tuple[float, float]]
    preprocessing: Preprocessing
    columns: Callable[[Prepared, list[str]], np.ndarray]
    joints: int | None = None
    sample_period: float | None = None
    check_joints: Callable[[list[str]], None] | None = None
    info: Any = None
    min_speed: float | None = None


def _emps_columns(p: Prepared, joints: list[str]) -> np.ndarray:
    return p.qdd[:, :1]


def _no_columns(p: Prepared, joints: list[str]) -> np.ndarray:
    return np.zeros((p.qd.size, 0))


def _tx40_j2_columns(p: Prepared, joints: list[str]) -> np.ndarray:
    from frictionid_core.robots.tx40 import DH, joint2_columns

    # The thesis formula is written in the DH angle θ₂ = q₂ + θoffset₂ (q₂ = 0: arm upright).
    return joint2_columns(p.q[:, 0] + DH[1][3], p.qdd[:, 0])


SYSTEMS: dict[str, System] = {
    # EMPS (1-DOF prismatic): τ = M·q̈ + τ_f(q̇) + offset; protocol of SPEC §5.1 at 1 kHz.
    "emps": System("emps", ("M",), {"M": (0.0, 500.0)},
                   Preprocessing(cutoff_hz=100.0, order=4, decimate=10, trim_start=49), _emps_columns,
                   joints=1),
    # Friction only (the rigid-body torque already removed from the effort): τ = τ_f(q̇) + offset.
    "friction-only": System("friction-only", (), {}, Preprocessing(), _no_columns),
    # TX40 joint 2, thesis §5.2 (SPEC §2.2): τ = ZZ·q̈ + τ_grav(q) + τ_f(q̇) + offset,
    # τ_grav = −g·MX·cos θ + g·MY·sin θ with the DH angle θ = q − π/2. Pre-processing and
    # slow-row exclusion as the robot systems (see frictionid_core.robots.system), except a
    # decimation by 2 (joint-2 reversals are slow; it halves the rows of the thesis' searches).
    "tx40-j2": System("tx40-j2", ("ZZ", "MX", "MY"), {"ZZ": (0.0, 5.0), "MX": (-10.0, 10.0), "MY": (-10.0, 10.0)},
                      Preprocessing(cutoff_hz=50.0, order=4, decimate=2, trim_start=200, trim_end=200),
                      _tx40_j2_columns, joints=1, min_speed=3e-3),
}

# Systems built on request (they need Pinocchio): full TX40 and any URDF.
ROBOT_SYSTEMS = ("tx40", "urdf:PATH")
JOINT_MAP_SEP = "?map="


def system_spec(name: str, joint_map: str | dict | None = None) -> str:
    """The system name carrying a ``{bag joint: model joint}`` map (``--joint-map a=b,c=d``):
    ``tx40?map=a=b,c=d``. Identification results store this name, so validation rebuilds the
    same system."""
    from frictionid_core.robots.system import format_joint_map, parse_joint_map

    jm = parse_joint_map(joint_map)
    base = name.split(JOINT_MAP_SEP, 1)[0]
    return f"{base}{JOINT_MAP_SEP}{format_joint_map(jm)}" if jm else base


def get_system(name: str) -> System:
    """A system by name: one of SYSTEMS, ``tx40`` (all six joints, Pinocchio) or ``urdf:PATH``
    (any fixed-base URDF), optionally with a joint map (see :func:`system_spec`)."""
    if name in SYSTEMS:
        return SYSTEMS[name]
    base, _, jmap = name.partition(JOINT_MAP_SEP)
    if base == "tx40":
        return _robot_system(name, None)
    if base.startswith("urdf:"):
        path = Path(base[len("urdf:"):]).expanduser()
        if not path.is_file():
            raise FrictionIdError(f"system '{name}': no such URDF file '{path}'")
        return _robot_system(name, path.stat().st_mtime_ns)
    if base in SYSTEMS and jmap:
        raise FrictionIdError(f"system '{base}' takes no joint map; select joints with --joints")
    raise FrictionIdError(f"unknown system '{name}'; choose one of {', '.join(list(SYSTEMS) + list(ROBOT_SYSTEMS))}")


@functools.lru_cache(maxsize=16)
def _robot_system(name: str, stamp: int | None) -> System:
    """Robot systems are cached per name (and URDF modification time): the base parameters
    are computed once."""
    from frictionid_core.robots.model import load_urdf
    from frictionid_core.robots.system import parse_joint_map, robot_system
    from frictionid_core.robots.tx40 import build_tx40

    base, _, jmap = name.partition(JOINT_MAP_SEP)
    robot = build_tx40() if base == "tx40" else load_urdf(Path(base[len("urdf:"):]).expanduser())
    return robot_system(robot, name, parse_joint_map(jmap or None))


def observe(series: JointSeries, system: System, settings: Preprocessing | None = None) -> Observation:
    """Pre-process ``series`` and build the decimated observation of ``system``."""
    if system.joints is not None and len(series.joints) != system.joints:
        raise InputError(
            f"{series.source}: system '{system.name}' models {system.joints} joint(s) but the data has "
            f"{len(series.joints)}: {series.joints}; select with --joints"
        )
    if system.check_joints is not None:
        system.check_joints(list(series.joints))
    settings = settings or system.preprocessing
    prepared = prepare(series, settings, dt=system.sample_period)
    rigid = system.columns(prepared, series.joints)
    obs = build_observation(prepared, series.joints, rigid, list(system.rigid_names), settings)
    if system.min_speed:
        exclude_slow_rows(obs, system.min_speed)
    return obs


def exclude_slow_rows(obs: Observation, min_speed: float) -> int:
    """Zero the rows of ``obs`` whose joint speed is below ``min_speed`` (they then add nothing
    to any least-squares cost or fit metric); returns how many rows were excluded."""
    nd = obs.n_samples
    count = 0
    for j in range(len(obs.joints)):
        slow = np.abs(obs.velocity[:, j]) < min_speed
        if not slow.any():
            continue
        count += int(slow.sum())
        rows = j * nd + np.flatnonzero(slow)
        obs.y[rows] = 0.0
        obs.rigid[rows] = 0.0
        obs.velocity[slow, j] = 0.0
        for col in obs.columns[j].values():
            col[slow] = 0.0
    return count
