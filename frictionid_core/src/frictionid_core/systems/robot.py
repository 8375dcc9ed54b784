"""Full-robot systems on a Pinocchio model: the TX40 (``tx40``) and any fixed-base URDF.

:func:`robot_system` gives a :class:`~frictionid_core.systems.system.System` whose rigid
columns are the robot's *base* regressor (Pinocchio's joint torque regressor, 10 parameters
per body, plus one rotor-inertia column q̈_j per joint, reduced to the base parameters by QR
with column pivoting): τ = W_b(q, q̇, q̈)·β + τ_f(q̇) + offset. Rows are the data's joints
(joint-major); the data hold every model joint (bag names matched to model names through
the system's joint map) or the fit holds the others still (:func:`restricted_system`: the base
parameters of that regressor). What the data resolve is checked on the fit's own rows
(:mod:`frictionid_core.identification.identifiability`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.preprocess import Prepared, Preprocessing
from frictionid_core.robots import MotorSide, base_parameter_names, restricted_base_parameters, robot_base_parameters
from frictionid_core.systems.system import RobotInfo, System

# Robot data: every setting chosen from the data (frictionid_core.preprocess): the cut-off from
# the motion's bandwidth keeps q̈ above the position noise; the analysis rate ≥ 10 × the cut-off;
# trims of 5/fc at both ends cover the forward–backward filter's edge transient; rows slower than
# 10 σ of the velocity noise (and 5e-4 × the top speed) are left out (the sign of q̇ is noise
# there, one wrong sign a 2·Fs outlier). A Stribeck dip crossed at reversals faster than those
# rates follow makes identify() refit at the rates the dip needs.
ROBOT_PREPROCESSING = Preprocessing()

# Restricted base parameters already computed: {(id of the RobotInfo, held, rows): (that RobotInfo, base)}.
_RESTRICTED: dict = {}
_RESTRICTED_MAX = 16


def robot_system(robot, name: str, joint_map: dict[str, str] | None = None, base=None,
                 preprocessing: Preprocessing = ROBOT_PREPROCESSING, drive=None) -> System:
    """The full-robot system ``name`` of ``robot`` (a RobotModel); ``base``: its base parameters
    (default: computed). With a ``drive`` whose friction acts on the motors the rows are its
    motors (:class:`~frictionid_core.robots.motor_side.MotorSide`: body columns mapped by C⁻ᵀ,
    one rotor inertia per motor on ẇ) and the base parameters are those of that regressor."""
    rows = None
    if drive is not None and drive.friction_on == "motor":
        rows = MotorSide(robot, drive)
    base = base or robot_base_parameters(robot, rows=rows)
    info = RobotInfo(robot, base, rows)
    names = tuple(base_parameter_names(base))
    bounds = _bounds(names, base.from_standard(robot.parameters()))
    return System(name, tuple(robot.joints), info.columns, names, bounds, preprocessing, dict(joint_map or {}),
                  robot=info, drive=drive)


def _bounds(names: tuple[str, ...], nominal: np.ndarray) -> dict[str, tuple[float, float]]:
    """Search bounds of base parameters around their model values (only solvers searching every
    parameter use them; use --varpro instead)."""
    return {n: (-max(1.0, 10.0 * abs(v)), max(1.0, 10.0 * abs(v))) for n, v in zip(names, nominal)}


def restricted_system(system: System, held: dict[str, float], rows: list[str]) -> System:
    """``system`` (a robot system) on data whose model joints ``held`` stay still at those
    positions (rad or m) and whose fitted rows are the model joints ``rows``: its base parameters
    those of that regressor (:func:`~frictionid_core.robots.base.restricted_base_parameters`:
    a body no fitted row feels drops out, bodies moving together regroup). ``system`` itself when
    nothing is held and every joint is fitted, or when its rows are a drive's motors."""
    info = system.robot
    if info is None or info.rows is not None or (not held and set(rows) == set(system.joints)):
        return system
    key = (id(info), tuple(sorted(held.items())), tuple(rows))
    if key not in _RESTRICTED:
        if len(_RESTRICTED) >= _RESTRICTED_MAX:
            _RESTRICTED.pop(next(iter(_RESTRICTED)))
        _RESTRICTED[key] = (info, restricted_base_parameters(info.model, info.base, held, rows))
    restricted = replace(info, base=_RESTRICTED[key][1])
    names = tuple(base_parameter_names(restricted.base))
    return replace(system, columns=restricted.columns, rigid_names=names, robot=restricted,
                   rigid_bounds=_bounds(names, restricted.base.from_standard(info.model.parameters())))


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

    def columns(p: Prepared, joints: list[str], rows: list[str] | None = None) -> np.ndarray:
        return info.base_columns(p.q, p.qd, p.qdd, joints, rows) @ transform

    scale = np.maximum(1.0, 10.0 * np.abs(nominal[rotor]))
    bounds = {LINK_TORQUE: (0.0, 2.0), **{n: (0.0, float(s)) for n, s in zip(names[1:], scale)}}
    fit = replace(system, columns=columns, rigid_names=names, rigid_bounds=bounds)
    return KnownRigidBody(system, fit, tuple(names[1:]), beta_links, rotor_map)

