"""The :class:`System` type (an inverse dynamic model without its friction) and :func:`observe`.

A system turns pre-processed signals into the full-rate rigid-body columns of the
observation matrix, says which data joints it models and how its data are pre-processed by
default.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.observation import Observation, build_observation
from frictionid_core.preprocess import Prepared, Preprocessing, prepare
from frictionid_core.timeseries import JointSeries

if TYPE_CHECKING:
    from frictionid_core.drive import Drive


@dataclass(frozen=True)
class RobotInfo:
    """The robot behind a robot system: its model and base parameters (of ``rows``, the
    regressor of the fit rows: the model's own, or its motor rows under a drive whose friction
    acts on the motors)."""

    model: object  # frictionid_core.robots.model.RobotModel
    base: object  # frictionid_core.robots.base.BaseParameters
    rows: object = None  # frictionid_core.robots.motor_side.MotorSide, or None: joint rows

    def base_columns(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, joints: list[str]) -> np.ndarray:
        """Base regressor rows (J·N, r), joint-major in the order of the model joints ``joints``
        (with motor rows: row block k is the motor of ``joints[k]``); q, q̇, q̈ (N, J) hold every
        model joint in that order (rad, rad/s, rad/s²)."""
        index = {j: k for k, j in enumerate(self.model.joints)}
        order = [index[j] for j in joints]
        n = q.shape[0]
        qm, qdm, qddm = (np.empty((n, self.model.nv)) for _ in range(3))
        qm[:, order], qdm[:, order], qddm[:, order] = q, qd, qdd
        Y = self.base.reduce((self.rows or self.model).regressor(qm, qdm, qddm))  # (N, nv, r)
        return np.concatenate([Y[:, m, :] for m in order], axis=0)


@dataclass(frozen=True)
class System:
    """An inverse dynamic model without its friction.

    Attributes:
        name: system id (``emps``, ``friction-only``, ``tx40``, ``urdf:PATH``, …).
        joints: the data joints it models: their count, the model's joint names (the data must
            hold each, through ``joint_map``), or None (any joints).
        columns: prepared signals + model joint names (data order) → rigid columns (J·N, R),
            joint-major rows.
        rigid_names: rigid-body parameter names (R).
        rigid_bounds: default search bounds of those parameters.
        preprocessing: default pre-processing.
        joint_map: {data joint name: model joint name} where they differ.
        min_speed: rows whose (decimated) joint speed |q̇| is below this are left out of the
            identification (zeroed: torque, every column and the velocity), because the sign of
            a noisy velocity near a reversal is unreliable and one wrong sign is a 2·Fs outlier;
            None keeps every row. Same unit as the velocity (m/s or rad/s).
        robot: the robot model and base parameters of a robot system (None otherwise).
        drive: the transmission between the log and the model's joints (None: the log is on
            the joint side, in N·m and rad). With ``friction_on: motor`` the fit rows are the
            drive's motors (see :func:`observe`); a robot system's columns are then its motor rows.
    """

    name: str
    joints: int | tuple[str, ...] | None
    columns: Callable[[Prepared, list[str]], np.ndarray]
    rigid_names: tuple[str, ...]
    rigid_bounds: dict[str, tuple[float, float]]
    preprocessing: Preprocessing
    joint_map: dict[str, str] = field(default_factory=dict)
    min_speed: float | None = None
    robot: RobotInfo | None = None
    drive: Drive | None = None

    @property
    def motor_rows(self) -> bool:
        """True when the fit rows are the drive's motors (``friction_on: motor``)."""
        return self.drive is not None and self.drive.friction_on == "motor"

    def model_joints(self, joints: list[str]) -> list[str]:
        """The model's names of the data joints ``joints``."""
        return [self.joint_map.get(j, j) for j in joints]

    def check_joints(self, joints: list[str], source: str = "") -> None:
        """Raise InputError when the data joints ``joints`` (of ``source``) do not fit the system."""
        where = f"{source}: " if source else ""
        if isinstance(self.joints, int):
            if len(joints) != self.joints:
                raise InputError(f"{where}system '{self.name}' models {self.joints} joint(s) but the data has "
                                 f"{len(joints)}: {list(joints)}; select with --joints")
            return
        if self.joints is None:
            return
        mapped = self.model_joints(joints)
        unknown = [j for j, m in zip(joints, mapped) if m not in self.joints]
        if unknown:
            hint = "" if self.joint_map else "; map names with --joint-map BAG=MODEL,…"
            raise InputError(f"{where}system '{self.name}': joint(s) {unknown} of the data are not in the model "
                             f"(model joints: {list(self.joints)}){hint}")
        dup = sorted({m for m in mapped if mapped.count(m) > 1})
        if dup:
            raise InputError(f"{where}system '{self.name}': several data joints map to model joint(s) {dup}")
        missing = [m for m in self.joints if m not in mapped]
        if missing:
            raise InputError(f"{where}system '{self.name}' needs every joint of its model: missing from the data: "
                             f"{missing} (data joints: {list(joints)}); for one joint of the TX40 use --system tx40-j2")


def parse_joint_map(text: str | None) -> dict[str, str]:
    """``bag=model,bag2=model2`` (the ``--joint-map`` option) → {bag: model}."""
    out = {}
    for item in filter(None, (s.strip() for s in (text or "").split(","))):
        bag, sep, model = item.partition("=")
        if not sep or not bag.strip() or not model.strip():
            raise InputError(f"--joint-map item '{item}': expected BAG_NAME=MODEL_NAME[,…]")
        out[bag.strip()] = model.strip()
    return out


def observe(series: JointSeries, system: System, settings: Preprocessing | None = None) -> Observation:
    """Pre-process ``series`` and build the decimated observation of ``system``
    (``settings`` overrides the system's pre-processing).

    A system with a drive first takes the log to the joint side (:meth:`Drive.to_joint_side`).
    With friction on the motors the rows are the referred motor torques u = C⁻ᵀ·τ, named after
    the motors, with the referred velocity w = C·q̇ as each row's friction velocity (ẇ = C·q̈).
    """
    drive = system.drive
    if drive is not None:
        series = drive.to_joint_side(series, system.joint_map)
    system.check_joints(list(series.joints), series.source)
    settings = settings or system.preprocessing
    prepared = prepare(series, settings)
    rigid = system.columns(prepared, system.model_joints(list(series.joints)))
    rows, row_names = prepared, list(series.joints)
    if system.motor_rows:
        rows = replace(prepared, qd=drive.motor_velocity(prepared.qd), qdd=drive.motor_velocity(prepared.qdd),
                       tau=drive.referred_motor_torque(prepared.tau))
        row_names = drive.motor_names()
    obs = build_observation(rows, row_names, rigid, list(system.rigid_names), settings)
    if system.motor_rows:
        obs.coupling, obs.data_joints = drive.C, list(series.joints)
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
