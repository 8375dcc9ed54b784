"""A robot seen from its motors: the regressor of a drive whose friction acts on the motors
(docs/reference.md#idm-motor-side).

With ``friction_on: motor`` (:mod:`frictionid_core.drive.transmission`) each motor's friction and rotor inertia
act on its referred velocity ``w = C·q̇``. In the referred motor torques ``u = C⁻ᵀ·τ`` every
motor's terms then sit in its own row:

    u = C⁻ᵀ·Y_body(q, q̇, q̈)·π_body + diag(C·q̈)·Ia_motor + f(w) + offset

so the rows are motors, the body columns are Pinocchio's joint torque regressor mapped by C⁻ᵀ,
and the rotor column of motor m is ẇ_m = (C·q̈)_m in row m (it replaces the joint armature
columns of :meth:`~frictionid_core.robots.robot_model.RobotModel.regressor`). Standard parameters:
the 10 per body (``<joint>.m`` …), then one rotor inertia per motor (``motor_<k>.Ia``, referred
to the joint side through the motor's own ratio, kg·m²).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.robots.robot_model import BODY_PARAMS, ROTOR_PARAM, param_name


@dataclass(frozen=True)
class MotorSide:
    """The motor rows of ``robot`` under ``drive`` (friction on the motors), in the robot's joint order.

    Attributes:
        robot: the RobotModel.
        drive: the Drive; its joints must be the robot's joints (any order).
        C: referred motor←joint matrix in the robot's joint order, (nv, nv).
        motors: motor name of each robot joint (the motor with that joint's own ratio).
    """

    robot: object
    drive: object
    C: np.ndarray = field(init=False, repr=False)
    motors: list[str] = field(init=False)

    def __post_init__(self) -> None:
        joints, model = list(self.drive.joints), list(self.robot.joints)
        if sorted(joints) != sorted(model):
            raise InputError(f"drive '{self.drive.name}' joints {joints} are not the joints of {self.robot.name} "
                             f"{model}: a drive with friction on the motors names the model's joints")
        order = [joints.index(j) for j in model]
        object.__setattr__(self, "C", self.drive.C[np.ix_(order, order)])
        object.__setattr__(self, "motors", [self.drive.motor_names()[k] for k in order])

    def parameter_names(self) -> list[str]:
        """Standard parameters: 10 per body, then one rotor inertia per motor."""
        bodies = [param_name(j, p) for j in self.robot.joints for p in BODY_PARAMS]
        return bodies + [f"{m}.{ROTOR_PARAM}" for m in self.motors]

    def parameters(self) -> np.ndarray:
        """Nominal standard parameters: the model's bodies; its armature as each motor's rotor inertia."""
        return self.robot.parameters()

    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Standard regressor of the motor rows for samples (N, nv) → (N, nv, 10·nb + nv)."""
        Y = self.robot.regressor(q, qd, qdd)
        nbody = Y.shape[2] - self.robot.nv
        out = np.empty_like(Y)
        out[:, :, :nbody] = np.einsum("jm,njp->nmp", np.linalg.inv(self.C), Y[:, :, :nbody])
        out[:, :, nbody:] = 0.0
        idx = np.arange(self.robot.nv)
        out[:, idx, nbody + idx] = np.atleast_2d(qdd) @ self.C.T
        return out

    def rotor_torques(self, qdd: np.ndarray, inertia: np.ndarray) -> np.ndarray:
        """Joint torques Cᵀ·(Ia ⊙ C·q̈) of the motor rotor inertias ``inertia`` (nv,) for q̈ (N, nv)."""
        return ((np.atleast_2d(qdd) @ self.C.T) * inertia) @ self.C
