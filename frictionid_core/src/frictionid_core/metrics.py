"""Fit metrics (docs/reference.md#metrics): relative error, R², RMSE, error std, improvement."""

from __future__ import annotations

import numpy as np


def relerr_pct(y: np.ndarray, y_hat: np.ndarray) -> float:
    """100·‖y − ŷ‖₂ / ‖y‖₂, %."""
    return float(100.0 * np.linalg.norm(y - y_hat) / np.linalg.norm(y))


def fit_metrics(y: np.ndarray, y_hat: np.ndarray) -> dict[str, float]:
    """relerr_pct (%), r2, rmse and error_std (units of y), error_norm (‖y − ŷ‖₂)."""
    y = np.ravel(y)
    e = y - np.ravel(y_hat)
    ss_res = float(e @ e)
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    return {
        "relerr_pct": relerr_pct(y, y_hat),
        "r2": 1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan"),
        "rmse": float(np.sqrt(ss_res / y.size)),
        "error_std": float(np.std(e, ddof=1)),
        "error_norm": float(np.sqrt(ss_res)),
    }


def improvement_pct(err_new: float, err_ref: float) -> float:
    """Δ = 100·(1 − ε_new/ε_ref), %."""
    return 100.0 * (1.0 - err_new / err_ref)
