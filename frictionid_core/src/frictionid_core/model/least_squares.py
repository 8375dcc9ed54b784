"""Linear least squares by QR with the statistics of the estimates, and the bounded quadratic
program (:func:`box_quadratic`) that holds the constraint policy in the closed forms."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionid_core.errors import FrictionIdError


@dataclass
class LinearFit:
    """θ̂ = argmin ‖y − Xθ‖₂ and its statistics.

    Attributes:
        coef: estimates (L,).
        std: σ of each estimate = std(residual)·sqrt(diag((XᵀX)⁻¹)) (L,).
        cond: 2-norm condition number of X.
    """

    coef: np.ndarray
    std: np.ndarray
    cond: float


def least_squares(X: np.ndarray, y: np.ndarray, names: list[str] | None = None) -> LinearFit:
    """Solve by economic QR of the columns scaled to unit norm (their units do not decide what is
    rank-deficient); rank-deficient X raises an error naming the collinear columns."""
    X = np.ascontiguousarray(X)  # one memory layout: one rounding of the sums below
    norms = np.linalg.norm(X, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    Q, R = np.linalg.qr(X / scale)  # economic; numpy: the least-squares path imports no scipy
    diag = np.abs(np.diag(R))
    tol = max(X.shape) * np.finfo(float).eps * (diag.max() if diag.size else 0.0)
    if diag.size and diag.min() <= tol:
        bad = [names[i] if names else str(i) for i in np.flatnonzero(diag <= tol)]
        raise FrictionIdError(
            f"observation matrix is rank-deficient: parameter(s) {bad} are not identifiable from "
            "these data (not excited, or collinear with others)"
        )
    coef = np.linalg.solve(R, Q.T @ y) / scale
    resid = y - X @ coef
    Rinv = np.linalg.solve(R, np.eye(R.shape[0]))
    std = np.std(resid, ddof=1) * np.sqrt(np.sum(Rinv**2, axis=1)) / scale
    s = np.linalg.svd(X, compute_uv=False)
    return LinearFit(coef, std, float(s[0] / s[-1]))


def box_quadratic(G: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """argmin ½zᵀGz − bᵀz subject to lo ≤ z ≤ hi, for each of P problems at once.

    G (P, n, n) symmetric positive definite, b (P, n), lo/hi (n,) or (P, n) with ±inf for no
    bound and lo = hi for a fixed entry. Primal active set: every bound a free entry crosses is
    made active; then the active bound whose multiplier has the wrong sign is released, one per
    problem per step. Returns (z (P, n), held (P, n): entries at a bound); z is always feasible.
    """
    n_pop, n = b.shape
    lo, hi = np.broadcast_to(lo, (n_pop, n)), np.broadcast_to(hi, (n_pop, n))
    held = lo == hi
    value = np.where(held, lo, 0.0)
    z = _equality_solve(G, b, held, value)
    rows = np.arange(n_pop)
    for _ in range(4 * n + 10):
        zr, hr, lr, ur = z[rows], held[rows], lo[rows], hi[rows]
        below, above = ~hr & (zr < lr), ~hr & (zr > ur)
        crossed = below | above
        # Multipliers of the held bounds: at a lower bound the cost must not fall as z grows (g ≥ 0).
        g = np.einsum("pij,pj->pi", G[rows], zr) - b[rows]
        wrong = np.where(hr & (lr != ur), np.where(value[rows] == lr, -g, g), 0.0)
        tol = 1e-8 * np.max(np.abs(b[rows]), axis=1, keepdims=True)
        release = ~crossed.any(axis=1) & (wrong > tol).any(axis=1)
        held[rows] |= crossed
        value[rows] = np.where(below, lr, np.where(above, ur, value[rows]))
        held[rows[release], np.argmax(wrong[release], axis=1)] = False
        rows = rows[crossed.any(axis=1) | release]
        if rows.size == 0:
            return z, held
        z[rows] = _equality_solve(G[rows], b[rows], held[rows], value[rows])
    while True:  # cycling (degenerate problems): make every problem feasible, bounds only added
        below, above = ~held & (z < lo), ~held & (z > hi)
        crossed = (below | above).any(axis=1)
        if not crossed.any():
            return z, held
        held |= below | above
        value = np.where(below, lo, np.where(above, hi, value))
        z[crossed] = _equality_solve(G[crossed], b[crossed], held[crossed], value[crossed])


def _equality_solve(G: np.ndarray, b: np.ndarray, held: np.ndarray, value: np.ndarray) -> np.ndarray:
    """argmin ½zᵀGz − bᵀz with the ``held`` entries (P, n) at ``value``: their rows and columns
    become the identity and their known contribution moves to the right-hand side."""
    known = np.where(held, value, 0.0)
    rhs = np.where(held, known, b - np.einsum("pij,pj->pi", G, known))
    free = ~held
    M = G * (free[:, :, None] & free[:, None, :]) + np.eye(b.shape[1]) * held[:, None, :]
    return np.linalg.solve(M, rhs[..., None])[..., 0]
