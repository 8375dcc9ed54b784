"""Decimated observation data shared by every inverse dynamic model.

An inverse dynamic model contributes *rigid* columns (terms linear in the rigid-body
parameters, e.g. q̈ for a mass); friction contributes columns built from the velocity. Every
column that depends on measured signals only (q̈, q̇, sign(q̇), their asymmetric masks, 1) is
computed at full rate and then decimated with the torque (docs/reference.md#emps-decimation). Terms of
nonlinear friction models that depend on searched parameters (the Stribeck/Threlfall dip) are
evaluated at the decimated velocity.

Rows are stacked joint-major: rows ``j·Nd … (j+1)·Nd − 1`` belong to joint j.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from frictionid_core.errors import FrictionIdError

from frictionid_core.preprocess import Prepared, Preprocessing, decimate, decimation_indices

VELOCITY_COLUMNS = ("V", "S", "V_pos", "S_pos", "V_neg", "S_neg", "one")


@dataclass
class Observation:
    """Identification data after decimation.

    Attributes:
        joints: joint names (J).
        y: measured torque/force rows, (J·Nd,).
        rigid: rigid-body columns, (J·Nd, R).
        rigid_names: names of the rigid-body parameters (R).
        velocity: decimated velocity, (Nd, J).
        columns: per joint, decimated velocity columns: V = q̇, S = sign(q̇), and the
            asymmetric V_pos = q̇·O⁺, S_pos = sign(q̇)·O⁺, V_neg, S_neg, and the constant
            ``one`` (decimated like the others: the anti-alias filter's DC gain is 0.989); each (Nd,).
        t: decimated sample times, s (Nd,).
        coupling: None when the rows are joint torques; under a drive whose friction acts on the
            motors (rows = referred motor torques u = C⁻ᵀ·τ, ``joints`` = its motor names) the
            drive's C (J, J), which :meth:`joint_torques` maps back with.
        data_joints: the data joints behind the rows, in row order (default: ``joints``).
    """

    joints: list[str]
    y: np.ndarray
    rigid: np.ndarray
    rigid_names: list[str]
    velocity: np.ndarray
    columns: list[dict[str, np.ndarray]]
    t: np.ndarray
    coupling: np.ndarray | None = None
    data_joints: list[str] | None = None

    @property
    def n_samples(self) -> int:
        """Decimated samples per joint (Nd)."""
        return self.velocity.shape[0]

    @property
    def torque_joints(self) -> list[str]:
        """The joint of each block of :meth:`joint_torques` (the data joints)."""
        return list(self.data_joints or self.joints)

    def joint_torques(self, rows: np.ndarray) -> np.ndarray:
        """Joint torques τ = Cᵀ·u of torque rows (…, J·Nd) (``y`` or predictions), joint-major in
        :attr:`torque_joints` order; the rows themselves when they are joint torques."""
        if self.coupling is None:
            return rows
        u = rows.reshape(rows.shape[:-1] + (len(self.joints), self.n_samples))
        return np.einsum("mj,...mn->...jn", self.coupling, u).reshape(rows.shape)


def velocity_columns(qd: np.ndarray) -> np.ndarray:
    """(N, 7) full-rate columns in VELOCITY_COLUMNS order for one joint's velocity (N,)."""
    s = np.sign(qd)
    pos = (1.0 + s) / 2.0
    neg = (1.0 - s) / 2.0
    return np.column_stack([qd, s, qd * pos, s * pos, qd * neg, s * neg, np.ones_like(qd)])


def build_observation(prepared: Prepared, joints: list[str], rigid_full: np.ndarray,
                      rigid_names: list[str], settings: Preprocessing) -> Observation:
    """Decimate torque, rigid columns (J·N, R) and velocity columns in one pass per joint.

    ``rigid_full`` rows are joint-major over the full-rate prepared samples.
    """
    n, nj = prepared.qd.shape
    r = rigid_full.shape[1]
    blocks, ys, cols, vels = [], [], [], []
    for j in range(nj):
        full = np.column_stack([
            prepared.tau[:, j], prepared.qd[:, j], rigid_full[j * n : (j + 1) * n],
            velocity_columns(prepared.qd[:, j])])
        dec = decimate(full, settings.decimate)
        ys.append(dec[:, 0])
        vels.append(dec[:, 1])
        blocks.append(dec[:, 2 : 2 + r])
        cols.append(dict(zip(VELOCITY_COLUMNS, dec[:, 2 + r :].T)))
    t = prepared.t[decimation_indices(n, settings.decimate)]
    return Observation(list(joints), np.concatenate(ys), np.vstack(blocks), list(rigid_names),
                       np.column_stack(vels), cols, t)



def concat_observations(observations: list[Observation]) -> Observation:
    """Observations of several sources (same joints) stacked into one: joint j's rows of every
    source in turn, so rows stay joint-major; ``t`` restarts with each source.

    Generic over the fields: an array with J·Nd rows is joint-major, one with Nd rows is per
    sample, per-joint column dicts are joined column by column, and any other field (names, …)
    must be equal in every observation.
    """
    first = observations[0]
    if len(observations) == 1:
        return first
    nj = len(first.joints)
    parts = {}
    for f in fields(Observation):
        values = [getattr(o, f.name) for o in observations]
        sizes = [o.n_samples for o in observations]
        if isinstance(values[0], np.ndarray) and all(v.shape[0] == nj * n for v, n in zip(values, sizes)):
            parts[f.name] = np.concatenate([v[j * n : (j + 1) * n] for j in range(nj) for v, n in zip(values, sizes)])
        elif isinstance(values[0], np.ndarray) and all(v.shape[0] == n for v, n in zip(values, sizes)):
            parts[f.name] = np.concatenate(values)
        elif f.name == "columns":
            parts[f.name] = [{k: np.concatenate([v[j][k] for v in values]) for k in values[0][j]} for j in range(nj)]
        elif all(_equal(v, values[0]) for v in values[1:]):
            parts[f.name] = values[0]
        else:
            raise FrictionIdError(f"cannot stack the observations of several sources: their '{f.name}' differ")
    return Observation(**parts)


def _equal(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(a, b))
    return a == b
