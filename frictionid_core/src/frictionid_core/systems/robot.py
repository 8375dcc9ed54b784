"""Full-robot systems on a Pinocchio model: the TX40 (``tx40``) and any fixed-base URDF.

:func:`robot_system` gives a :class:`~frictionid_core.systems.system.System` whose rigid
columns are the robot's *base* regressor (Pinocchio's joint torque regressor, 10 parameters
per body, plus one rotor-inertia column q̈_j per joint, reduced to the base parameters by QR
with column pivoting): τ = W_b(q, q̇, q̈)·β + τ_f(q̇) + offset. Rows are the data's joints
(joint-major); the data must hold every model joint (bag names matched to model names through
the system's joint map). The columns of the data are checked for rank before any solve
(:attr:`System.excitation`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.preprocess import Prepared, Preprocessing
from frictionid_core.robots.base import base_parameter_names, robot_base_parameters
from frictionid_core.systems.system import RobotInfo, System

# Robot data: every setting chosen from the data (frictionid_core.preprocess): the cut-off from
# the motion's bandwidth keeps q̈ above the position noise; the analysis rate ≥ 10 × the cut-off;
# trims of 5/fc at both ends cover the forward–backward filter's edge transient; rows slower than
# 10 σ of the velocity noise (and 5e-4 × the top speed) are left out (the sign of q̇ is noise
# there, one wrong sign a 2·Fs outlier). A Stribeck dip crossed at reversals faster than those
# rates follow makes identify() refit at the rates the dip needs.
ROBOT_PREPROCESSING = Preprocessing()

# Rows of the excitation test: one in this many samples, more on long logs (at most about
# _CHECK_SAMPLES samples: the pivoted QR of every tenth sample of a 5 kHz minute takes seconds).
_CHECK_STRIDE = 10
_CHECK_SAMPLES = 5000


def robot_system(robot, name: str, joint_map: dict[str, str] | None = None, base=None,
                 preprocessing: Preprocessing = ROBOT_PREPROCESSING, drive=None) -> System:
    """The full-robot system ``name`` of ``robot`` (a RobotModel); ``base``: its base parameters
    (default: computed). With a ``drive`` whose friction acts on the motors the rows are its
    motors (:class:`~frictionid_core.robots.motor_side.MotorSide`: body columns mapped by C⁻ᵀ,
    one rotor inertia per motor on ẇ) and the base parameters are those of that regressor."""
    rows = None
    if drive is not None and drive.friction_on == "motor":
        from frictionid_core.robots.motor_side import MotorSide

        rows = MotorSide(robot, drive)
    base = base or robot_base_parameters(robot, rows=rows)
    info = RobotInfo(robot, base, rows)
    names = tuple(base_parameter_names(base))
    nominal = base.from_standard(robot.parameters())
    # Bounds only matter for solvers searching every parameter (use --varpro instead).
    bounds = {n: (-max(1.0, 10.0 * abs(v)), max(1.0, 10.0 * abs(v))) for n, v in zip(names, nominal)}

    def columns(p: Prepared, joints: list[str]) -> np.ndarray:
        return info.base_columns(p.q, p.qd, p.qdd, joints)

    def excitation(cols: np.ndarray, p: Prepared, joints: list[str]) -> tuple[np.ndarray, list[str]]:
        if rows is None:
            return _excitation_rows(cols, p.qd, joints, list(names))
        # friction on each motor's referred velocity; data joints are in the drive's order
        return _excitation_rows(cols, drive.motor_velocity(p.qd), drive.motor_names(), list(names))

    return System(name, tuple(robot.joints), columns, names, bounds, preprocessing, dict(joint_map or {}),
                  robot=info, drive=drive, excitation=excitation)


def nominal_parameters(system: System) -> dict[str, float]:
    """{base parameter name: value} of a robot system's own model (its rigid body as modelled:
    what ``IdentifyRequest(fixed=...)`` takes to identify friction only on a known arm)."""
    info = system.robot
    if info is None:
        raise FrictionIdError(f"system '{system.name}' has no robot model (tx40 or urdf:PATH only)")
    return dict(zip(system.rigid_names, map(float, info.base.from_standard(info.model.parameters()))))


# The parameter of the model's link torque column in a known-rigid-body fit (held at 1).
LINK_TORQUE = "link_torque"


@dataclass(frozen=True)
class KnownRigidBody:
    """A robot system with its links as modelled and its rotor inertias to identify
    (``IdentifyRequest(known_rigid_body=True)``).

    The fit's rigid columns are the model's link torque W_b·β_links (parameter
    :data:`LINK_TORQUE`, held at 1) and one rotor column W_b·A[:, Ia] per joint or motor (its
    standard name, ``<joint>.Ia`` / ``motor_<k>.Ia``): the base regressor W_b, β_links the base
    parameters of the links alone (every rotor inertia 0), A the base map
    (:meth:`~frictionid_core.robots.base.BaseParameters.combination_matrix`).

    Attributes:
        system: the robot system (its base parameters are what a result reports).
        fit_system: the system of the fit (the columns above).
        rotor_names: the rotor inertias' names.
        links: β_links (r,).
        rotor_map: A[:, Ia] (r, rotors): base parameters = links + rotor_map·Ia.
    """

    system: System
    fit_system: System
    rotor_names: tuple[str, ...]
    links: np.ndarray
    rotor_map: np.ndarray

    def base_parameters(self, rotor: np.ndarray) -> np.ndarray:
        """The system's base parameters (r,) for rotor inertias ``rotor`` (rotors,)."""
        return self.links + self.rotor_map @ np.asarray(rotor, dtype=float)

    def held(self) -> list[str]:
        """The base parameters no rotor inertia enters: held at the model's values."""
        return [n for n, row in zip(self.system.rigid_names, self.rotor_map) if not np.any(row)]


def known_rigid_body(system: System) -> KnownRigidBody:
    """The known-rigid-body fit of the robot ``system`` (see :class:`KnownRigidBody`)."""
    info = system.robot
    if info is None:
        raise FrictionIdError(f"system '{system.name}' has no robot model: known_rigid_body needs tx40 or urdf:PATH")
    rows = info.rows or info.model
    standard = rows.parameter_names()
    nominal = np.asarray(rows.parameters(), dtype=float)
    rotor = np.arange(len(standard) - info.model.nv, len(standard))
    links = nominal.copy()
    links[rotor] = 0.0
    beta_links = info.base.from_standard(links)
    rotor_map = info.base.combination_matrix()[:, rotor]
    transform = np.column_stack([beta_links, rotor_map])
    names = (LINK_TORQUE, *(standard[i] for i in rotor))

    def columns(p: Prepared, joints: list[str]) -> np.ndarray:
        return info.base_columns(p.q, p.qd, p.qdd, joints) @ transform

    def excitation(cols: np.ndarray, p: Prepared, joints: list[str]) -> tuple[np.ndarray, list[str]]:
        """The rank test of the rotor columns (the held link torque column is known)."""
        if info.rows is None:
            return _excitation_rows(cols[:, 1:], p.qd, joints, list(names[1:]))
        drive = info.rows.drive
        return _excitation_rows(cols[:, 1:], drive.motor_velocity(p.qd), drive.motor_names(), list(names[1:]))

    scale = np.maximum(1.0, 10.0 * np.abs(nominal[rotor]))
    bounds = {LINK_TORQUE: (0.0, 2.0), **{n: (0.0, float(s)) for n, s in zip(names[1:], scale)}}
    fit = replace(system, columns=columns, rigid_names=names, rigid_bounds=bounds, excitation=excitation)
    return KnownRigidBody(system, fit, tuple(names[1:]), beta_links, rotor_map)


def _excitation_rows(rows: np.ndarray, qd: np.ndarray, joints: list[str], names: list[str]
                     ) -> tuple[np.ndarray, list[str]]:
    """(rows, names) of the rank test of the data: the rigid + Coulomb/viscous columns on a subset
    of the samples (``qd``: each row block's friction velocity, ``joints``: the blocks' names)."""
    nj, n = len(joints), qd.shape[0]
    sel = np.arange(0, n, max(_CHECK_STRIDE, n // _CHECK_SAMPLES))
    rigid = np.concatenate([rows[j * n + sel] for j in range(nj)], axis=0)
    fric = np.zeros((rigid.shape[0], 2 * nj))
    for j in range(nj):
        v = qd[sel, j]
        fric[j * sel.size : (j + 1) * sel.size, 2 * j] = v
        fric[j * sel.size : (j + 1) * sel.size, 2 * j + 1] = np.sign(v)
    fnames = [f"{j}/{p}" for j in joints for p in ("Fv", "Fc")]
    return np.hstack([rigid, fric]), names + fnames
