"""σ of the estimates of an optimiser's fit, from the residual Jacobian at its solution."""

from __future__ import annotations

import numpy as np

from frictionid_core.identification_model import IdentificationModel


def jacobian_std(model: IdentificationModel, x: np.ndarray) -> tuple[dict[str, float], np.ndarray]:
    """σ of each estimate from the residual Jacobian at x: std(e)·sqrt(diag((JᵀJ)⁻¹)), and the
    design matrix at x (R, L).

    The prediction is linear in the linear parameters: their columns of J are the design
    matrix's; central differences for the free nonlinear ones (all perturbed predictions in one
    batched call); σ 0 for fixed parameters. NaN where J is rank-deficient (a parameter without
    influence, e.g. a dip that vanished).
    """
    free = model.free_index
    X = model.design(x[None])[0] if not model.is_linear else model.design()
    position = {int(i): k for k, i in enumerate(model.linear_index)}
    J = np.empty((X.shape[0], free.size))
    linear = np.array([k for k, i in enumerate(free) if int(i) in position], dtype=int)
    J[:, linear] = X[:, [position[int(free[k])] for k in linear]]
    nonlinear = np.setdiff1d(np.arange(free.size), linear)
    if nonlinear.size:
        index = free[nonlinear]
        h = 1e-6 * np.maximum(np.abs(x[index]), 1e-3)
        steps = np.zeros((index.size, model.k))
        steps[np.arange(index.size), index] = h
        pred = model.predict(np.vstack([x + steps, x - steps]))
        J[:, nonlinear] = (pred[: index.size] - pred[index.size :]).T / (2.0 * h)
    e = model.residuals(x)
    try:
        cov = np.linalg.inv(J.T @ J)
        sd = np.std(e, ddof=1) * np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        sd = np.full(free.size, np.nan)
    std = dict.fromkeys(model.names, 0.0)
    std.update((model.names[i], float(v)) for i, v in zip(free, sd))
    return std, X
