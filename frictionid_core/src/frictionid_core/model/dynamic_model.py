"""The identification model of a dynamic friction law (LuGre, Maxwell-slip): parameters → torque rows.

The parameter vector is that of :class:`~frictionid_core.model.identification_model.IdentificationModel`
(rigid body, per joint the law's parameters, offsets). The rigid-body parameters, Fv and the
offsets enter linearly (their columns as for a static law); every other friction parameter
(Fc, Fs, vs and the pre-sliding ones: σ0, σ1 or k1 … kn) shapes the law's state-dependent part,
integrated along each row joint's travel (the observation's ``path`` and ``shift``, else its
velocity) at the observation's times (:func:`~frictionid_core.friction.states.joint_state_rows`),
and is nonlinear. Variable projection
(:meth:`DynamicIdentificationModel.solve_linear`) solves the linear ones in closed form for given
nonlinear ones, within the same box as for a static law.

The observation is a full one (:attr:`~frictionid_core.model.observation.Observation.full`: every row,
standstill and reversals included), whose ``moving`` rows are those a static law would fit; the
states run through every row, the model's cost counts every used row.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import joint_state_rows
from frictionid_core.model.identification_model import IdentificationModel


@dataclass
class DynamicIdentificationModel(IdentificationModel):
    """Torque prediction and least-squares cost of a dynamic friction law on ``obs`` (see the module doc)."""

    def __post_init__(self) -> None:
        if not self.friction.is_dynamic:
            raise FrictionIdError(f"{self.friction.label} is a static law: use IdentificationModel")
        super().__post_init__()
        obs = self.obs
        nj, nf, r = len(obs.joints), len(self.friction.names), len(obs.rigid_names)
        self.joint_index = r + np.arange(nj)[:, None] * nf + np.arange(nf)[None, :]  # (J, nf) into the vector
        linear = set(self.linear_index.tolist())
        self.nonlinear_index = np.array([i for i in self.joint_index.ravel() if i not in linear], dtype=int)
        self._viscous = np.array([k for k, n in enumerate(self.friction.names) if n.startswith("Fv")], dtype=int)
        scale = obs.used.reshape(nj, obs.n_samples).astype(float)
        if obs.weight is not None:
            scale = scale * obs.weight[None, :]
        if obs.joint_weight is not None:
            scale = scale * obs.joint_weight[:, None]
        self._row_scale = scale
        self._travel = None
        if obs.path is not None:  # a reset starts at rest below the joint's rest speed (its velocity noise)
            rest = obs.report.get("rest_speed_rows") or {}
            self._travel = (obs.path, obs.shift, np.array([rest.get(j) or 0.0 for j in obs.joints], dtype=float))

    def state_rows(self, params: np.ndarray) -> np.ndarray:
        """The law's state-dependent friction (all but Fv·v) on the rows, for parameters (P, k) →
        (P, R): zero on unused rows, weighted like the others."""
        p = np.atleast_2d(np.asarray(params, dtype=float))
        theta = p[:, self.joint_index]  # (P, J, nf)
        theta[:, :, self._viscous] = 0.0  # Fv·v is a linear column
        rows = joint_state_rows(self.friction, theta, self.obs.velocity, self.obs.t, self._travel)
        rows = rows * self._row_scale[None]
        return rows.reshape(p.shape[0], -1)

    def predict(self, params: np.ndarray) -> np.ndarray:
        """Torque rows for parameters (P, k) → (P, R), or (k,) → (R,)."""
        p, single = self.population(params)
        pred = p[:, self.linear_index] @ self._fixed.T + self.state_rows(p)
        return pred[0] if single else pred

    def batch_cost(self, params: np.ndarray) -> np.ndarray:
        """Sum of squared torque residuals for a population (P, k) → (P,)."""
        return np.sum((self.obs.y[None, :] - self.predict(np.atleast_2d(params))) ** 2, axis=1)

    def design(self, theta: np.ndarray | None = None) -> np.ndarray:
        """Columns of the linear parameters (R, L), or (P, R, L) for ``theta`` (P, k): they do not
        depend on the nonlinear parameters (the state-dependent part is not a column)."""
        if theta is None:
            return self._fixed
        return np.broadcast_to(self._fixed, (np.atleast_2d(theta).shape[0],) + self._fixed.shape).copy()

    def solve_linear(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Variable projection: for each row of ``theta`` (P, k) keep its nonlinear entries (fixed ones
        at their values), solve the linear ones in closed form on the rows less the state-dependent
        friction, within their box. Returns (full parameters (P, k), costs (P,))."""
        p = np.array(np.atleast_2d(theta), dtype=float)
        for i, v in self.fixed_values.items():
            p[:, i] = v
        FtF, Fty, _, _ = self._quadratic
        rest = self.obs.y[None, :] - self.state_rows(p)
        b = rest @ self._fixed
        coef = self._solve_normal(np.repeat(FtF[None], p.shape[0], axis=0), b)[0]
        p[:, self.linear_index] = coef
        return p, np.sum((rest - coef @ self._fixed.T) ** 2, axis=1)

    def fit_linear(self) -> tuple[np.ndarray, dict[str, float], float]:
        """Closed-form least squares of the linear parameters with every nonlinear one fixed (see
        :meth:`IdentificationModel.fit_linear`), on the rows less the state-dependent friction."""
        if self.searched_nonlinear_index.size:
            return super().fit_linear()  # refused, naming the parameters
        x = self.embed(np.empty((1, 0)), np.empty(0, dtype=int))
        shifted = replace(self.obs, y=self.obs.y - self.state_rows(x)[0])
        return IdentificationModel.fit_linear(replace(self, obs=shifted))

    def state_part(self, x: np.ndarray) -> np.ndarray:
        """The prediction of ``x`` (k,) that is not in :meth:`design`'s columns: its state rows (R,)."""
        return self.state_rows(np.asarray(x, dtype=float)[None])[0]
