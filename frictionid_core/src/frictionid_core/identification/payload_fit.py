"""The payload's fit on the residual of a known robot (:func:`fit_payload`): what the data resolve,
the held values of the rest, the consistent estimate and its σ.

The torque the base result leaves unexplained on the loaded log, r, is fitted by the payload's
ten columns A (link frame) and, on request, the friction levels' columns F:
r ≈ A·z + F·f. In order:

1. every parameter free (least squares): the inertia about the centre of mass is *resolved*
   entry by entry when its σ is below :data:`INERTIA_SHARE` × m·ℓ² (ℓ = max(|c|,
   :data:`REACH_FLOOR_M`): the inertia of the payload's mass at its reach); the others are held
   at the point mass' value (:func:`~frictionid_core.robots.payload_model.point_inertia`, off-diagonal 0);
2. with those held, a centre-of-mass coordinate is resolved when its σ is below
   :data:`COM_TOLERANCE_M`, else held at 0 (the link frame's origin); the mass must be resolved
   (σ below :data:`MASS_SHARE` of it), else the log cannot say what the payload is (an error);
3. the consistent estimate (:func:`~frictionid_core.consistency.payload_sdp.consistent_body`) with the
   held values, recomputed from its own mass and centre of mass until they agree.

σ: the delta method on the Jacobian of the held-completed parameters at the solution, from the
HAC covariance robust to coloured residuals (:func:`~frictionid_core.identification.uncertainty.hac_covariance`;
the base result's model errors leave correlated residuals) and the white one (kept in ``fit``);
the larger of the two per quantity; each with what the base's own σ (its robust σ, its parameters'
errors taken as independent) moves the payload by, since the base is held, not known.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from frictionid_core.consistency import consistent_body
from frictionid_core.errors import InputError
from frictionid_core.identification.uncertainty import hac_covariance
from frictionid_core.robots import INERTIA_ENTRIES, QUANTITIES, body_quantities, point_inertia

MASS_SHARE = 0.05
COM_TOLERANCE_M = 0.01
INERTIA_SHARE = 0.1
REACH_FLOOR_M = 0.05
# Index of each inertia entry about the centre of mass in the standard parameters' I_o (Ixx, Ixy, Iyy, Ixz, Iyz, Izz).
INERTIA_INDEX = {"xx": 4, "xy": 5, "yy": 6, "xz": 7, "yz": 8, "zz": 9}
HELD_ITERATIONS = 20
HELD_TOLERANCE = 1e-10
NEWTON_STEPS = 5


@dataclass
class PayloadFit:
    """The fit's outcome.

    Attributes:
        z: standard parameters (10,), link frame; friction: the friction levels (nf,).
        quantities, sigma: :data:`~frictionid_core.robots.payload_model.QUANTITIES` and their σ (NaN: held).
        friction_sigma: σ of the friction levels (nf,).
        resolved: the quantities the data resolve; held: {quantity: value} of the others.
        record: the ``fit`` block (SDP, iterations, thresholds, σ kind, cost increase).
    """

    z: np.ndarray
    friction: np.ndarray
    quantities: np.ndarray
    sigma: np.ndarray
    friction_sigma: np.ndarray
    resolved: list[str]
    held: dict[str, float]
    record: dict


class _Problem:
    """r ≈ A·z(θ) + F·f on the used rows, z completed from its free entries θ (``free``, (10,) bool)."""

    def __init__(self, A: np.ndarray, F: np.ndarray, r: np.ndarray, used: np.ndarray, instants: int):
        self.A, self.F, self.r = A * used[:, None], F * used[:, None], r * used
        self.used, self.instants = used, instants

    @staticmethod
    def complete(theta: np.ndarray, free: np.ndarray) -> np.ndarray:
        """z (10,) of the free entries ``theta``: a held centre-of-mass coordinate at 0, a held
        inertia entry at the point mass' value about the centre of mass."""
        z = np.zeros(10)
        z[free] = theta
        if not free[4:].all():
            m, h = z[0], z[1:4]
            c = h / m if m > 0 else np.zeros(3)
            I_o = point_inertia(m) + m * (c @ c * np.eye(3) - np.outer(c, c))
            for key, k in INERTIA_INDEX.items():
                if not free[k]:
                    z[k] = I_o[INERTIA_ENTRIES[key]]
        return z

    def jacobian(self, theta: np.ndarray, free: np.ndarray) -> np.ndarray:
        """d z / d θ (10, k) by central differences (exact for the free entries)."""
        out = np.zeros((10, theta.size))
        for i in range(theta.size):
            step = 1e-6 * max(abs(theta[i]), 1e-3)
            d = np.zeros(theta.size)
            d[i] = step
            out[:, i] = (self.complete(theta + d, free) - self.complete(theta - d, free)) / (2 * step)
        return out

    def design(self, theta: np.ndarray, free: np.ndarray) -> np.ndarray:
        """The residual Jacobian [A·dz/dθ | F] (R, k + nf)."""
        return np.hstack([self.A @ self.jacobian(theta, free), self.F])

    def residual(self, z: np.ndarray, f: np.ndarray) -> np.ndarray:
        return (self.r - self.A @ z - self.F @ f) * self.used

    def newton(self, theta: np.ndarray, f: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unconstrained least squares over (θ, f) by Gauss–Newton (exact in one step when nothing is held)."""
        k = theta.size
        for _ in range(NEWTON_STEPS):
            step = np.linalg.lstsq(self.design(theta, free), self.residual(self.complete(theta, free), f),
                                   rcond=None)[0]
            theta, f = theta + step[:k], f + step[k:]
            if np.max(np.abs(step)) <= 1e-12 * max(1.0, np.max(np.abs(theta))):
                break
        return theta, f

    def covariances(self, theta: np.ndarray, f: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(white, HAC) covariances of (θ, f) at a solution."""
        J = self.design(theta, free)
        e = self.residual(self.complete(theta, free), f)
        dof = max(int(np.count_nonzero(self.used)) - J.shape[1], 1)
        white = (e @ e / dof) * np.linalg.inv(J.T @ J)
        robust, _ = hac_covariance(J, e, self.instants)
        return white, robust

    def quantity_sigma(self, theta: np.ndarray, f: np.ndarray, free: np.ndarray, base: tuple | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(σ of the quantities (10,), σ of the friction levels, white σ of the quantities): the
        larger of the white and the robust σ, by the delta method; with ``base`` (the base's held
        columns B (R, L), their σ (L,)) also what the base's own errors move the fit by."""
        k = theta.size
        D = np.zeros((10, k))
        for i in range(k):
            step = 1e-6 * max(abs(theta[i]), 1e-3)
            d = np.zeros(k)
            d[i] = step
            D[:, i] = (body_quantities(self.complete(theta + d, free))
                       - body_quantities(self.complete(theta - d, free))) / (2 * step)
        white, robust = self.covariances(theta, f, free)
        if base is not None:  # the base's errors δβ move the fit by −(JᵀJ)⁻¹Jᵀ·B·δβ (independent errors assumed)
            J = self.design(theta, free)
            M = np.linalg.lstsq(J, base[0] * self.used[:, None], rcond=None)[0] * base[1]
            white, robust = white + M @ M.T, robust + M @ M.T
        sw = np.sqrt(np.clip(np.diag(D @ white[:k, :k] @ D.T), 0, None))
        sr = np.sqrt(np.clip(np.diag(D @ robust[:k, :k] @ D.T), 0, None))
        fs = np.sqrt(np.clip(np.maximum(np.diag(white)[k:], np.diag(robust)[k:]), 0, None))
        return np.maximum(sw, sr), fs, sw


def fit_payload(A: np.ndarray, F: np.ndarray, r: np.ndarray, used: np.ndarray, instants: int,
                nonnegative: np.ndarray, f0: np.ndarray, base: tuple[np.ndarray, np.ndarray] | None = None
                ) -> PayloadFit:
    """The payload (and, with columns F, friction level) fit of the module doc: A (R, 10) the
    payload's columns, F (R, nf) the friction levels' (nf may be 0), r (R,) the torque left by the
    base with friction levels ``f0`` (nf,) — the columns' fit is of r + F·f0 —, ``used`` (R,) the
    rows fitted, ``instants`` the samples per joint (rows are joint-major), ``nonnegative`` (nf,)
    the levels held ≥ 0; ``base``: the base's held columns (R, L) and their σ (L,), whose errors the
    reported σ carries (what the loaded log resolves is judged on its own σ)."""
    p = _Problem(A, F, r + F @ f0, used, instants)
    free = np.ones(10, dtype=bool)
    theta, f = p.newton(np.zeros(10), np.asarray(f0, dtype=float).copy(), free)
    q = body_quantities(theta)
    sigma, _, _ = p.quantity_sigma(theta, f, free)
    if not (q[0] > 0 and sigma[0] <= MASS_SHARE * q[0]):
        raise InputError(f"the log does not resolve the payload's mass ({q[0]:.4g} ± {sigma[0]:.3g} kg): record motion "
                         "that moves the link against gravity in several poses, with the payload fixed")
    reach = max(float(np.linalg.norm(q[1:4])), REACH_FLOOR_M)
    for key, k in INERTIA_INDEX.items():
        if sigma[QUANTITIES.index(f"inertia.{key}")] > INERTIA_SHARE * q[0] * reach**2:
            free[k] = False
    if not free.all():
        theta, f = p.newton(theta[free], f, free)
    sigma, _, _ = p.quantity_sigma(theta, f, free)
    for i in range(3):
        if sigma[1 + i] > COM_TOLERANCE_M:
            free[1 + i] = False
    if not free[1:4].all():
        z = p.complete(theta, np.concatenate([free[:1], [True] * 3, free[4:]]))
        theta, f = p.newton(z[free], f, free)
    z_unc = p.complete(theta, free)
    cost_unc = float(np.sum(p.residual(z_unc, f) ** 2))
    z, f, record, iterations = _consistent(p, z_unc, f, free, nonnegative)
    theta = z[free]
    sigma, fsigma, white = p.quantity_sigma(theta, f, free, base)
    resolved = [name for name, k in zip(QUANTITIES, _quantity_free(free)) if k]
    quantities = body_quantities(z)
    sigma[~_quantity_free(free)] = np.nan
    white[~_quantity_free(free)] = np.nan
    cost = float(np.sum(p.residual(z, f) ** 2))
    record.update(iterations=iterations, cost_increase_pct=100.0 * (cost - cost_unc) / max(cost_unc, 1e-300),
                  sigma="the larger of the white-residual and the HAC (Newey–West) σ, delta method",
                  sigma_white=sigma_block(white),
                  thresholds={"mass_share": MASS_SHARE, "com_m": COM_TOLERANCE_M, "inertia_share": INERTIA_SHARE,
                              "reach_floor_m": REACH_FLOOR_M},
                  unconstrained=dict(zip(QUANTITIES, map(float, body_quantities(z_unc)))))
    held = {name: float(v) for name, v, k in zip(QUANTITIES, quantities, _quantity_free(free)) if not k}
    return PayloadFit(z, f, quantities, sigma, fsigma, resolved, held, record)


def _quantity_free(free: np.ndarray) -> np.ndarray:
    """Which :data:`QUANTITIES` are free (resolved) for the free standard parameters ``free``."""
    inertia = [free[INERTIA_INDEX[q.split(".")[1]]] for q in QUANTITIES[4:]]
    return np.array([free[0], *free[1:4], *inertia], dtype=bool)


def _consistent(p: _Problem, z: np.ndarray, f: np.ndarray, free: np.ndarray, nonnegative: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, dict, int]:
    """The consistent estimate from the unconstrained ``z``, ``f``: the SDP with the held entries
    at their values for the current mass and centre of mass, until they no longer change."""
    S = np.eye(10)[:, free]
    G = np.hstack([p.A @ S, p.F])
    Q, R = np.linalg.qr(G)
    scale = np.linalg.norm(R, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    norm = max(float(np.linalg.norm(p.r)), 1e-300)
    record: dict = {}
    for iteration in range(1, HELD_ITERATIONS + 1):
        held = np.where(free, 0.0, z)
        target = Q.T @ (p.r - p.A @ held)
        z_new, f, record = consistent_body(R / norm, target / norm, scale, held, S, nonnegative)
        change = float(np.max(np.abs(z_new - z)))
        z = p.complete(z_new[free], free)
        if free.all() or change <= HELD_TOLERANCE * max(1.0, float(np.max(np.abs(z)))):
            return z, f, record, iteration
    return z, f, record, HELD_ITERATIONS


def sigma_block(sigma: np.ndarray) -> dict:
    """{"mass", "com": [3], "inertia": [[3×3]]} of σ over :data:`QUANTITIES` (None where NaN)."""
    values = [None if not np.isfinite(s) else float(s) for s in sigma]
    inertia = [[None] * 3 for _ in range(3)]
    for name, value in zip(QUANTITIES[4:], values[4:]):
        a, b = INERTIA_ENTRIES[name.split(".")[1]]
        inertia[a][b] = inertia[b][a] = value
    return {"mass": values[0], "com": values[1:4], "inertia": inertia}


def base_columns(X: np.ndarray, names: list[str], base: Mapping) -> tuple[np.ndarray, np.ndarray] | None:
    """(the base's held columns ``X`` (R, L), their σ (L,): the base's robust σ, else its white σ, 0
    where it has none (fixed, undetermined)), or None when the base has no σ."""
    sd = base.get("std_robust") or base.get("std")
    sigma = np.array([float(sd.get(n) or 0.0) for n in names]) if sd else None
    return None if sigma is None else (X, np.where(np.isfinite(sigma), sigma, 0.0))
