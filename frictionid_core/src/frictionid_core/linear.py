"""Linear least squares by QR with the statistics of the estimates."""

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
