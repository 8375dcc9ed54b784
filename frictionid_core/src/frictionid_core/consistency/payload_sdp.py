"""The physically consistent payload: one body's least squares under a positive definite
pseudo-inertia, a convex program (cvxpy + Clarabel, as :mod:`~frictionid_core.consistency.fit`).

    minimise  ‖R·u − b‖²                    u = (θ, f): the payload's free parameters, friction levels
    subject to J(z) − ε·m·1 ⪰ 0,  z = z_held + S·θ   (4×4 pseudo-inertia, Wensing et al. 2017)
               f_k ≥ 0 where asked (Fv, Fc, Fs)

R, b: the triangular factor and projected target of the (scaled) least-squares problem, so the
program has as many rows as unknowns; z_held: the held parameters' values (0 where free), S
puts the free ones in place. ε = :data:`~frictionid_core.consistency.fit.MARGIN` relative
to the mass: the smallest eigenvalue passes the consistency check after the solver's round-off.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.consistency.check import PSEUDO_INERTIA_BASIS
from frictionid_core.consistency.fit import MARGIN, SOLVER, solve_program


def consistent_body(R: np.ndarray, b: np.ndarray, scale: np.ndarray, z_held: np.ndarray, S: np.ndarray,
                    nonnegative: np.ndarray, margin: float = MARGIN) -> tuple[np.ndarray, np.ndarray, dict]:
    """(the payload's standard parameters z (10,), the friction levels (nf,), {solver, status,
    sdp_wall_s}) minimising ‖R·(u / scale) − b‖² (u in the columns' units times ``scale``) under
    the module's constraints; ``S`` (10, k) places the k free parameters, ``nonnegative`` (nf,)
    marks the friction levels held ≥ 0."""
    import cvxpy as cp

    k = S.shape[1]
    v = cp.Variable(R.shape[1])
    u = cp.multiply(1.0 / scale, v)
    z = z_held + S @ u[:k]
    J = cp.Variable((4, 4), symmetric=True)
    cons = [J == sum(z[i] * PSEUDO_INERTIA_BASIS[i] for i in range(10)), J - margin * J[3, 3] * np.eye(4) >> 0]
    if np.any(nonnegative):
        cons.append(u[k:][np.flatnonzero(nonnegative)] >= 0)
    problem = cp.Problem(cp.Minimize(cp.sum_squares(R @ u - b)), cons)
    wall = solve_program(problem, v, "consistent payload")
    values = v.value / scale
    record = {"solver": f"cvxpy {cp.__version__} + {SOLVER}", "status": problem.status, "sdp_wall_s": wall,
              "margin": margin}
    return z_held + S @ values[:k], values[k:], record
