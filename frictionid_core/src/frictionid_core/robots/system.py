"""Identification systems built on a Pinocchio robot model.

``robot_system(robot)`` gives a :class:`~frictionid_core.systems.System` whose rigid columns
are the robot's *base* regressor (Pinocchio's joint torque regressor, 10 parameters per body,
plus one rotor-inertia column q̈_j per joint, reduced to the base parameters by QR with column
pivoting). Rows are the data's joints (joint-major); the data must hold every model joint
(bag names matched to model names, through an optional ``{bag name: model name}`` map).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.preprocess import Preprocessing

# Robot data: zero-phase 50 Hz Butterworth on position (excitation trajectories are slow; the
# lower cut-off cuts the noise of q̈) and no decimation: the model evaluates the Stribeck dip
# at the (decimated) velocity while the measured torque would be low-passed by the decimation
# filter, and at a fast reversal (|q̈| ≈ 9 rad/s² crosses a 0.025 rad/s dip in ~5 ms) even the
# 200 Hz anti-alias filter of decimation by 2 biases vs and δ. 200 samples are trimmed at each
# end: the edge transient of the forward–backward 50 Hz filter (odd-reflection padding flips
# the sign of q̈ at the edge) still biases q̈ after 50 ms.
ROBOT_PREPROCESSING = Preprocessing(cutoff_hz=50.0, order=4, decimate=1, trim_start=200, trim_end=200)
# Rows with |q̇| below this (rad/s) are left out: near a reversal the sign of the estimated
# velocity is unreliable, and one wrong sign is a 2·Fs outlier that biases vs and δ.
ROBOT_MIN_SPEED = 3e-3

# Rows of the excitation test: one in this many samples.
_CHECK_STRIDE = 10


@dataclass
class RobotInfo:
    """What a robot system knows beyond the System fields (for reports and synthesis)."""

    robot: object  # RobotModel
    base: object  # BaseParameters
    joint_map: dict[str, str]

    def model_joint(self, data_joint: str) -> str:
        return self.joint_map.get(data_joint, data_joint)

    def base_names(self) -> list[str]:
        return base_parameter_names(self.base)

    def base_columns(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, joints: list[str]) -> np.ndarray:
        """Base regressor rows (J·N, r), joint-major in the order of ``joints`` (data names);
        q, q̇, q̈ (N, J) hold every model joint in that order."""
        index = {j: k for k, j in enumerate(self.robot.joints)}
        order = [index[self.model_joint(j)] for j in joints]
        n = q.shape[0]
        qm, qdm, qddm = (np.empty((n, self.robot.nv)) for _ in range(3))
        qm[:, order], qdm[:, order], qddm[:, order] = q, qd, qdd
        Y = self.base.reduce(self.robot.regressor(qm, qdm, qddm))  # (N, nv, r)
        return np.concatenate([Y[:, m, :] for m in order], axis=0)

    def true_base(self) -> dict[str, float]:
        """Base parameters of the model's own standard parameters (the truth of synthetic data)."""
        return dict(zip(self.base_names(), map(float, self.base.from_standard(self.robot.parameters()))))


def base_parameter_names(base) -> list[str]:
    """Base parameter names: the independent standard parameter, suffixed ``R`` when others
    are regrouped into it (Khalil's convention, e.g. ``joint_2.IzzR``)."""
    return [n + ("R" if np.any(base.K[k]) else "") for k, n in enumerate(base.base_names)]


def parse_joint_map(text: str | dict | None) -> dict[str, str]:
    """``bag=model,bag2=model2`` → {bag: model}."""
    if text is None or isinstance(text, dict):
        return dict(text or {})
    out = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        bag, sep, model = item.partition("=")
        if not sep or not bag.strip() or not model.strip():
            raise InputError(f"--joint-map item '{item}': expected BAG_NAME=MODEL_NAME[,…]")
        out[bag.strip()] = model.strip()
    return out


def format_joint_map(joint_map: dict[str, str]) -> str:
    return ",".join(f"{b}={m}" for b, m in joint_map.items())


def robot_system(robot, name: str, joint_map: dict[str, str] | None = None, base=None,
                 preprocessing: Preprocessing = ROBOT_PREPROCESSING):
    """The full-robot :class:`System` of ``robot``: τ = W_b(q, q̇, q̈)·β + τ_f(q̇) + offset."""
    from frictionid_core.robots.base import robot_base_parameters
    from frictionid_core.systems import System

    joint_map = dict(joint_map or {})
    base = base or robot_base_parameters(robot)
    info = RobotInfo(robot, base, joint_map)
    names = tuple(base_parameter_names(base))
    nominal = base.from_standard(robot.parameters())
    # Bounds only matter for solvers searching every parameter (use --varpro instead).
    bounds = {n: (-max(1.0, 10.0 * abs(v)), max(1.0, 10.0 * abs(v))) for n, v in zip(names, nominal)}
    index = {j: k for k, j in enumerate(robot.joints)}

    def check(joints: list[str]) -> None:
        mapped = [info.model_joint(j) for j in joints]
        unknown = [j for j, m in zip(joints, mapped) if m not in index]
        if unknown:
            hint = "" if joint_map else "; map names with --joint-map BAG=MODEL,…"
            raise InputError(f"system '{name}': joint(s) {unknown} of the data are not in the model {robot.name} "
                             f"(model joints: {robot.joints}){hint}")
        dup = sorted({m for m in mapped if mapped.count(m) > 1})
        if dup:
            raise InputError(f"system '{name}': several data joints map to model joint(s) {dup}")
        missing = [m for m in robot.joints if m not in mapped]
        if missing:
            raise InputError(f"system '{name}' needs every joint of {robot.name}: missing from the data: {missing} "
                             f"(data joints: {joints}); for one joint of the TX40 use --system tx40-j2")

    def columns(p, joints: list[str]) -> np.ndarray:
        check(joints)
        rows = info.base_columns(p.q, p.qd, p.qdd, joints)
        _check_rank(rows, p.qd, joints, p.q.shape[0], list(names), name)
        return rows

    sys_ = System(name, names, bounds, preprocessing, columns, joints=None, check_joints=check, info=info,
                  min_speed=ROBOT_MIN_SPEED)
    return sys_


def _check_rank(rows: np.ndarray, qd: np.ndarray, joints: list[str], n: int, names: list[str], name: str) -> None:
    """Raise when the rigid + Coulomb/viscous columns of the data are rank-deficient."""
    from frictionid_core.robots.base import check_excitation

    nj = len(joints)
    sel = np.arange(0, n, _CHECK_STRIDE)
    blocks = [rows[j * n + sel] for j in range(nj)]
    rigid = np.concatenate(blocks, axis=0)
    fric = np.zeros((rigid.shape[0], 2 * nj))
    for j in range(nj):
        v = qd[sel, j]
        fric[j * sel.size : (j + 1) * sel.size, 2 * j] = v
        fric[j * sel.size : (j + 1) * sel.size, 2 * j + 1] = np.sign(v)
    fnames = [f"{j}/{p}" for j in joints for p in ("Fv", "Fc")]
    check_excitation(np.hstack([rigid, fric]), names + fnames, f"system '{name}'")
