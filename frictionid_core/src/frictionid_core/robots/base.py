"""Base (identifiable) parameters by QR decomposition with column pivoting.

The standard regressor W (stacked over samples) has numerical rank r < P: some parameters
never act (zero columns) and others only act in fixed combinations. QR with column pivoting
W·Π = Q·R on random samples gives the rank r. The independent column set is then chosen in
the standard parameter order (a column is kept when it is not in the span of the columns kept
before it), not in pivot order: pivoting breaks ties between equal-norm columns by round-off,
so the base set, and thus the reported names, would depend on the machine's LAPACK. The other
columns satisfy W_d = W_b·K (least squares, exact up to round-off), so that

    W·π = W_b·(π_b + K·π_d)           base parameters β = π_b + K·π_d

The same K turns known standard parameters (a model, a ground truth) into base parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# |R_kk| / |R_00| below this is numerically zero (structural rank on random samples).
RANK_TOL = 1e-9
# Entries of K smaller than this are set to 0: round-off of exact structural zeros, or regroupings
# through offsets of a few µm (a URDF's 1e-5 m rounding) that no fit resolves. At 1e-10 an xArm7
# regrouping of −1.1e-10 came and went with the number of random samples, and so did its name
# (``joint2.Ia`` or ``joint2.IaR``): identify and validate named one parameter two ways.
K_TOL = 1e-8


@dataclass
class BaseParameters:
    """The base parameter set of a standard parameter vector.

    Attributes:
        names: standard parameter names (P).
        base_index: indices of the independent standard columns, in standard order (r).
        dependent_index: the other columns (P − r).
        K: (r, P − r), β = π[base_index] + K·π[dependent_index].
    """

    names: list[str]
    base_index: np.ndarray
    dependent_index: np.ndarray
    K: np.ndarray

    @property
    def rank(self) -> int:
        return int(self.base_index.size)

    @property
    def base_names(self) -> list[str]:
        """A base parameter is named after its independent standard parameter."""
        return [self.names[i] for i in self.base_index]

    def reduce(self, W: np.ndarray) -> np.ndarray:
        """Base columns of a standard regressor (…, P) → (…, r)."""
        return W[..., self.base_index]

    def from_standard(self, pi: np.ndarray) -> np.ndarray:
        """β = π_b + K·π_d."""
        pi = np.asarray(pi, dtype=float)
        return pi[self.base_index] + self.K @ pi[self.dependent_index]

    def combination_matrix(self) -> np.ndarray:
        """(r, P) matrix A with β = A·π."""
        A = np.zeros((self.rank, len(self.names)))
        A[np.arange(self.rank), self.base_index] = 1.0
        A[:, self.dependent_index] = self.K
        return A

    def describe(self) -> dict[str, str]:
        """{base name: 'a + 1·b − 0.225·c …'} (the regrouped standard parameters)."""
        out = {}
        for r, i in enumerate(self.base_index):
            terms = [self.names[i]]
            for c, d in zip(self.K[r], self.dependent_index):
                if c != 0.0:
                    terms.append(f"{'+' if c > 0 else '−'} {abs(c):.6g}·{self.names[d]}")
            out[self.names[i]] = " ".join(terms)
        return out

    def unidentifiable(self) -> list[str]:
        """Standard parameters with no effect on any torque (zero column: zero row of K too)."""
        return [self.names[d] for k, d in enumerate(self.dependent_index) if not np.any(self.K[:, k])]


def base_parameters(W: np.ndarray, names: list[str], tol: float = RANK_TOL) -> BaseParameters:
    """Base parameters of the stacked standard regressor W (rows, P) (see the module doc)."""
    from scipy import linalg  # pivoted QR (imported here: the one-joint systems need no scipy)

    W = np.asarray(W, dtype=float)
    if W.shape[0] < W.shape[1]:
        raise ValueError(f"need at least as many regressor rows as parameters ({W.shape[1]}), got {W.shape[0]}")
    _, R, _ = linalg.qr(W, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    rank = int(np.sum(d > tol * d[0])) if d.size and d[0] > 0 else 0
    keep = _independent_in_order(W, rank, tol)
    dep = np.setdiff1d(np.arange(W.shape[1]), keep)
    K = linalg.lstsq(W[:, keep], W[:, dep])[0] if keep.size else np.zeros((0, dep.size))
    K[np.abs(K) < K_TOL] = 0.0
    return BaseParameters(list(names), keep, dep, K)


def _independent_in_order(W: np.ndarray, rank: int, tol: float) -> np.ndarray:
    """The first ``rank`` columns of W, in column order, that are each independent of those kept
    before them (Gram–Schmidt with re-orthogonalisation; a column is dependent when its residual
    is below ``tol`` of the largest column norm)."""
    scale = np.linalg.norm(W, axis=0).max(initial=0.0)
    basis = np.zeros((W.shape[0], 0))
    keep = []
    for j in range(W.shape[1]):
        if len(keep) == rank:
            break
        v = W[:, j].copy()
        for _ in range(2):
            v -= basis @ (basis.T @ v)
        norm = np.linalg.norm(v)
        if norm > tol * scale:
            keep.append(j)
            basis = np.column_stack([basis, v / norm])
    return np.array(keep, dtype=int)


def base_parameter_names(base: BaseParameters) -> list[str]:
    """Base parameter names: the independent standard parameter, suffixed ``R`` when others
    are regrouped into it (Khalil's convention, e.g. ``joint_2.IzzR``)."""
    return [n + ("R" if np.any(base.K[k]) else "") for k, n in enumerate(base.base_names)]


def random_samples(robot, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n random (q, q̇, q̈) within the robot's limits (finite stand-ins for unlimited ones)."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    vmax = np.where(np.isfinite(robot.velocity_limit), robot.velocity_limit, 3.0)
    amax = np.where(np.isfinite(robot.acceleration_limit), robot.acceleration_limit, 10.0)
    q = rng.uniform(lo, hi, (n, robot.nv))
    qd = rng.uniform(-vmax, vmax, (n, robot.nv))
    qdd = rng.uniform(-amax, amax, (n, robot.nv))
    return q, qd, qdd


def robot_base_parameters(robot, samples: int | None = None, seed: int = 0, rows=None) -> BaseParameters:
    """Base parameters of ``robot`` (standard parameters + rotor inertias) from random samples;
    ``rows``: another regressor of the robot (``parameter_names()``, ``regressor(q, q̇, q̈)``,
    e.g. :class:`~frictionid_core.robots.motor_side.MotorSide`) instead of the robot's own."""
    rows = rows or robot
    names = rows.parameter_names()
    n = samples or max(50, 4 * len(names) // robot.nv + 10)
    q, qd, qdd = random_samples(robot, n, seed)
    Y = rows.regressor(q, qd, qdd)  # (n, nv, P)
    return base_parameters(Y.reshape(-1, Y.shape[-1]), names)


def restricted_base_parameters(robot, base: BaseParameters, held: dict[str, float], rows: list[str],
                               samples: int | None = None, seed: int = 0) -> BaseParameters:
    """Base parameters of ``robot`` (with its base parameters ``base``) when its joints ``held``
    stay still at those positions (rad or m; q̇ = q̈ = 0) and only the torques of the joints
    ``rows`` are observed: the base columns on random samples of that regressor, reduced again
    (:func:`base_parameters`) and composed with ``base``, so β' = A'·π with A' = A₂·A."""
    index = {j: k for k, j in enumerate(robot.joints)}
    n = samples or max(50, 4 * base.rank // max(1, len(rows)) + 10)
    q, qd, qdd = random_samples(robot, n, seed)
    for joint, value in held.items():
        k = index[joint]
        q[:, k], qd[:, k], qdd[:, k] = value, 0.0, 0.0
    W = base.reduce(robot.regressor(q, qd, qdd))[:, [index[j] for j in rows], :]
    second = base_parameters(W.reshape(-1, base.rank), [base.names[i] for i in base.base_index])
    A = second.combination_matrix() @ base.combination_matrix()
    keep = base.base_index[second.base_index]
    dependent = np.setdiff1d(np.arange(len(base.names)), keep)
    K = A[:, dependent]
    K[np.abs(K) < K_TOL] = 0.0
    return BaseParameters(list(base.names), keep, dependent, K)
