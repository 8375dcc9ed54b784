"""Friction feed-forward from the active parameters (no ROS import).

τ_ff[j] = FrictionModel.torque(θ_j, v[j], eps) of the core — the identified friction only
(no rigid-body terms, no ``offset``). Joints without parameters get 0.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.friction import FrictionModel
from frictionid_core.errors import FrictionIdError

from frictionid_ros.store import JointParams


class FeedForward:
    """Friction torque of joints ``joints`` [N·m | N] at velocities v [rad/s | m/s].

    Joints sharing a friction model are evaluated with one core call: ``torque`` of a (g, k)
    parameter block at the g velocities gives a (g, g) array whose diagonal is the answer.
    """

    def __init__(self, joints: list[str], eps: float = 0.0):
        self.joints = list(joints)
        self.eps = float(eps)
        self._groups: tuple[tuple[FrictionModel, np.ndarray, np.ndarray], ...] = ()
        self.active: tuple[str, ...] = ()

    def set_params(self, per_joint: dict[str, JointParams]) -> list[str]:
        """Use ``per_joint`` (joints not in :attr:`joints` are ignored); returns problems found."""
        groups: dict[FrictionModel, tuple[list[int], list[list[float]]]] = {}
        problems, active = [], []
        for i, j in enumerate(self.joints):
            p = per_joint.get(j)
            if p is None:
                continue
            try:
                model, vec = p.friction_vector()
            except FrictionIdError as exc:
                problems.append(str(exc))
                continue
            idx, rows = groups.setdefault(model, ([], []))
            idx.append(i)
            rows.append(vec)
            active.append(j)
        # One immutable tuple, swapped atomically: readers in other threads never see a half update.
        self._groups = tuple((m, np.array(idx, dtype=np.intp), np.array(rows, dtype=float))
                             for m, (idx, rows) in groups.items())
        self.active = tuple(active)
        return problems

    def torque(self, v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Friction torque (J,) at velocities v (J,); non-finite velocities give 0."""
        out = np.zeros(len(self.joints)) if out is None else out
        out.fill(0.0)
        for model, idx, params in self._groups:
            vv = v[idx]
            tau = model.torque(params, vv, self.eps)
            out[idx] = np.diagonal(tau)
        np.nan_to_num(out, copy=False, nan=0.0, posinf=0.0, neginf=0.0)
        return out
