"""Weighted least squares over the joints (Gautier's two-step estimate): each row joint's rows
weighted by 1/σ_j, σ_j the RMS residual of its used rows under the closed-form fit of the law's
linear special case (Coulomb).

A fit in N·m weighs every joint by its torque: a wrist of 0.1 N·m beside a shoulder of 100 N·m
hardly counts, so the link parameters both see are set by the shoulder's noise and the wrist's
friction takes what is left (UR wrists fitted at 10–20 % of their own torque, their Fv at 0,
beside a 1 % noise). Weighted by its own noise, each joint counts by the information it carries;
the weights are relative (the noisiest joint 1), so a one-joint fit is unchanged.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from frictionid_core.model import IdentificationModel

# A joint's residual is not credited below this share of its own RMS torque (a noise-free
# simulation fits to rounding; no sensor resolves its torque better).
SIGMA_FLOOR_SHARE = 1e-4


def joint_sigmas(model: IdentificationModel) -> np.ndarray | None:
    """σ_j (J,) of each row joint of the unweighted ``model``: the RMS residual of its used (and,
    for a dynamic law, moving) rows under the closed-form Coulomb fit, at least SIGMA_FLOOR_SHARE
    of its RMS torque there; NaN for a joint without such rows. None for fewer than two row joints."""
    from frictionid_core.identification.linear_case import linear_special_case

    obs = model.obs
    nj, nd = len(obs.joints), obs.n_samples
    if nj < 2:
        return None
    if obs.joint_weight is not None:
        raise ValueError("joint_sigmas needs the unweighted model")
    special, x = linear_special_case(model)
    rows = obs.used if obs.moving is None else obs.used & obs.moving
    rows = rows.reshape(nj, nd)
    count = rows.sum(axis=1)
    residual = (special.residuals(x).reshape(nj, nd) ** 2 * rows).sum(axis=1)
    torque = (obs.y.reshape(nj, nd) ** 2 * rows).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        sigma = np.sqrt(np.maximum(residual, SIGMA_FLOOR_SHARE**2 * torque) / count)
    return np.where((count > 0) & (sigma > 0), sigma, np.nan)


def weighted_model(model: IdentificationModel) -> IdentificationModel:
    """``model`` with each row joint weighted by 1/σ_j (:func:`joint_sigmas`), relative to the
    noisiest joint; ``model`` itself when already weighted, with one row joint, or when no σ is
    known (a joint without rows keeps weight 1)."""
    if model.obs.joint_weight is not None:
        return model
    sigma = joint_sigmas(model)
    if sigma is None or not np.isfinite(sigma).any():
        return model
    weight = np.where(np.isfinite(sigma), np.nanmax(sigma) / sigma, 1.0)
    return replace(model, obs=model.obs.joint_weighted(weight))


def unweighted_model(model: IdentificationModel) -> IdentificationModel:
    """``model`` on its unweighted rows (in N·m or N): ``model`` itself when not weighted."""
    return model if model.obs.joint_weight is None else replace(model, obs=model.obs.unweighted())
