"""Load-dependent Coulomb friction (``--load-dependent``): a geared joint's Coulomb level rises with
the torque it transmits, Fc + Fc_load·|τ_rigid|, τ_rigid the model's rigid-body torque of that
joint (or motor row: the rigid-body part of its referred torque).

In the identification model the term Fc_load·|τ_rigid|·sign(q̇) is one more linear column per row
joint (parameter ``<joint>/Fc_load``, N·m per N·m), after the offsets, whose values hold |τ_rigid|
of given rigid-body parameters (:func:`load_columns`); the identification alternates the closed
form with τ_rigid of its last solution (:mod:`frictionid_core.identification.load_dependent_fit`).
"""

from __future__ import annotations

import numpy as np

LOAD_NAME = "Fc_load"
# Search range of Fc_load (a fraction of the transmitted torque; solved in closed form otherwise).
LOAD_BOUNDS = (-1.0, 1.0)


def load_names(joints: list[str]) -> list[str]:
    """The load parameters of the row joints ``joints`` (``<joint>/Fc_load``; ``Fc_load`` alone for one)."""
    return [f"{j}/{LOAD_NAME}" if len(joints) > 1 else LOAD_NAME for j in joints]


def rigid_torque(obs, rigid: np.ndarray) -> np.ndarray:
    """τ_rigid (J·Nd,) of rigid-body parameters ``rigid`` (R,) on the rows of ``obs`` (unweighted: in N·m or N)."""
    tau = obs.rigid @ np.asarray(rigid, dtype=float)
    if obs.weight is not None:
        tau = tau / np.tile(np.where(obs.weight > 0, obs.weight, 1.0), len(obs.joints))
    if obs.joint_weight is not None:
        tau = tau / np.repeat(obs.joint_weight, obs.n_samples)
    return tau


def load_columns(obs, rigid: np.ndarray) -> list[np.ndarray]:
    """Per row joint (Nd,) |τ_rigid|·S: the column of its Fc_load (S the decimated sign column,
    weighted like the others)."""
    tau = np.abs(rigid_torque(obs, rigid)).reshape(len(obs.joints), obs.n_samples)
    return [tau[j] * obs.columns[j]["S"] for j in range(len(obs.joints))]
