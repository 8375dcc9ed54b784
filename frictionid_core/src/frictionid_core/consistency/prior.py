"""The robot model's (CAD, URDF) links as the prior of a consistent fit, on the directions the data do not
determine (docs/reference.md#consistent-parameters).

The log-det divergence d(J, J⁰) of a link's pseudo-inertia from the model's is, near J⁰, the
quadratic ½·Δπᵀ·M·Δπ with M_ij = tr(J⁰⁻¹E_i·J⁰⁻¹E_j) (:func:`divergence_metric`): ½ (Δm/m)² along a
link's mass, the same relative measure along its first and second moments. A prior of weight W is a
Gaussian of relative spread 1/√W in that metric.

The data's information on the standard parameters, with the friction levels and rotor inertias
taken out (a link's inertia about its axis and its rotor's add up in the data: the rotor, which URDFs
seldom hold, takes what they cannot tell apart), is compared with that metric along the generalised
eigenvectors v (F·v = λ·M·v, vᵀMv = 1): a direction whose λ is below :data:`HOLD_WEIGHT` is known
less well from the data than to 1/√HOLD_WEIGHT (10 %) of the link's scale, and the program holds it at
the model's value with that weight (:func:`undetermined_directions`). The directions the data do
determine are left to them alone: a link the data show far from the model stays so.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh

from frictionid_core.consistency.check import PSEUDO_INERTIA_BASIS, pseudo_inertia

# The prior's weight on the directions the data do not determine: a spread of 1/√100 = 10 % of a
# link's own scale, and the bar a direction's information must pass to be left to the data.
HOLD_WEIGHT = 100.0


def divergence_metric(link: np.ndarray) -> np.ndarray | None:
    """M (10, 10) of one link's standard parameters ``link`` ([m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz,
    Izz]): the Hessian of the log-det divergence at them; None when its pseudo-inertia is not
    positive definite (a massless link: no prior)."""
    J0 = pseudo_inertia(link)
    if np.linalg.eigvalsh(J0)[0] <= 0.0:
        return None
    inv = np.linalg.inv(J0)
    half = np.einsum("ab,ibc->iac", inv, PSEUDO_INERTIA_BASIS)  # J⁰⁻¹·E_i
    return np.einsum("iab,jba->ij", half, half)


def undetermined_directions(information: np.ndarray, prior: np.ndarray, scale: np.ndarray, links: int,
                            weight: float = HOLD_WEIGHT) -> tuple[np.ndarray, list[int]]:
    """(C (n, 10·k): the directions of the links' scaled standard parameters that the data do not
    determine, as rows a = C·(u − u⁰) of unit prior metric; the links with a prior).

    ``information``: the data's information F (N, N) on the scaled unknowns u (the standard
    parameters π = scale·u of ``links`` links first, 10 each, then the rest: rotor inertias,
    friction levels); ``prior``: the model's standard parameters (at least 10·links); ``scale``
    (≥ 10·links,): the scale of each. The rest and the links without a prior are taken out of F
    (Schur complement: what they can absorb is not the links'); a direction is undetermined when its
    information λ (F·v = λ·M·v) is below ``weight``."""
    metrics = [divergence_metric(prior[10 * k : 10 * k + 10]) for k in range(links)]
    with_prior = [k for k, m in enumerate(metrics) if m is not None]
    index = np.array([10 * k + i for k in with_prior for i in range(10)], dtype=int)
    if not index.size:
        return np.zeros((0, 0)), []
    rest = np.setdiff1d(np.arange(information.shape[0]), index)
    F = information[np.ix_(index, index)]
    if rest.size:
        cross = information[np.ix_(index, rest)]
        F = F - cross @ np.linalg.pinv(information[np.ix_(rest, rest)], hermitian=True) @ cross.T
    M = np.zeros((index.size, index.size))
    for n, k in enumerate(with_prior):
        s = scale[10 * k : 10 * k + 10]
        M[10 * n : 10 * n + 10, 10 * n : 10 * n + 10] = metrics[k] * np.outer(s, s)
    lam, V = eigh(0.5 * (F + F.T), M)
    held = V[:, lam < weight]
    return held.T @ M, with_prior
