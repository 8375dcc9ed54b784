"""The load-dependent Coulomb level identified with the rest (``load_dependent``): the model is
bilinear (Fc_load multiplies |τ_rigid|, which the rigid-body parameters set), so the fit alternates
the solver (in closed form for the linear parameters) with τ_rigid of its last solution until that
torque settles (:func:`fit_with_load`). See :mod:`frictionid_core.model.load_dependence`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from frictionid_core.identification.solve import Fit
from frictionid_core.model import IdentificationModel, rigid_torque

# At most this many rounds; settled when the rigid-body torque moves by less than LOAD_SETTLED of its norm.
LOAD_ROUNDS = 20
LOAD_SETTLED = 1e-7


def fit_with_load(model: IdentificationModel, first: Fit, warnings: list[str], refit: Callable[..., Fit]
                  ) -> tuple[IdentificationModel, Fit]:
    """(the load-dependent model, its fit) from ``model`` (no load dependence) and its fit
    ``first``: each round builds the load columns of the last solution's rigid-body parameters and
    calls ``refit(model, previous)`` (previous: the last point with its Fc_load, and the
    optimiser's result, for a local polish); a warning appended to ``warnings`` when LOAD_ROUNDS
    rounds do not settle it."""
    r = len(model.obs.rigid_names)
    x, fit = np.asarray(first.x, dtype=float), first
    load = np.zeros(len(model.obs.joints))
    tau = rigid_torque(model.obs, x[:r])
    rounds, settled = 0, False
    while rounds < LOAD_ROUNDS and not settled:
        loaded = replace(model, load_rigid=x[:r].copy())
        previous = None if fit.optim is None else Fit(np.concatenate([x, load]), optim=fit.optim)
        fit = refit(loaded, previous)
        x_all = np.asarray(fit.x, dtype=float)
        x, load = x_all[: model.k], x_all[model.k:]
        new_tau = rigid_torque(model.obs, x[:r])
        settled = bool(np.linalg.norm(new_tau - tau) <= LOAD_SETTLED * max(np.linalg.norm(tau), 1e-300))
        tau, rounds = new_tau, rounds + 1
    if not settled:
        warnings.append(f"the load-dependent Coulomb level did not settle in {rounds} rounds (the rigid-body "
                        "torque still moves): its Fc_load are approximate")
    return loaded, fit
