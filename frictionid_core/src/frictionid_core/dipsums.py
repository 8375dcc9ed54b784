"""Compiled sums of one friction dip over its active rows, for a whole population.

The cost and the variable projection of :class:`~frictionid_core.model.IdentificationModel`
need, per candidate i, only three reductions of the signed dip column d_i (n,) over the rows
where its branch is active: d_iᵀd_i, d_iᵀy and d_iᵀF (L,). One numba kernel computes them
without materialising the (P, n) dip array, one candidate per thread (``prange``), each sum
in a fixed order (results do not depend on the thread count), and skips rows whose dip is
exactly 0 in float64 (exp underflow; Threlfall beyond v0). On a machine without AVX-512,
numpy's float64 ``exp`` is scalar, so this halves the time on 2 cores.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

KIND_CODES = {"tustin": 0, "stribeck": 1, "threlfall": 2}
_E3 = 1.0 - math.exp(-3.0)
_EXP_UNDERFLOW = -745.2  # math.exp(x) == 0.0 below this
_STRIBECK_ZERO = 6.62  # exp(−exp(e)) == 0.0 above this


@njit(cache=True, parallel=True)
def _dip_sums(kind, theta, speed, log_speed, mask, F, y):  # pragma: no cover - compiled
    n_pop, n_rows, n_cols = theta.shape[0], speed.size, F.shape[1]
    s_dd = np.zeros(n_pop)
    s_dy = np.zeros(n_pop)
    s_dF = np.zeros((n_pop, n_cols))
    for i in prange(n_pop):
        a = theta[i, 0]
        b = theta[i, 1] if theta.shape[1] > 1 else 0.0
        inv = -1.0 / a
        log_vs = math.log(a) if kind == 1 else 0.0
        dd = 0.0
        dy = 0.0
        for r in range(n_rows):
            if kind == 0:  # tustin: exp(−|v|/vs)
                x = speed[r] * inv
                if x < _EXP_UNDERFLOW:
                    continue
                d = math.exp(x)
            elif kind == 1:  # stribeck: exp(−(|v|/vs)^δ)
                e = b * (log_speed[r] - log_vs)
                if e > _STRIBECK_ZERO:
                    continue
                d = math.exp(-math.exp(e))
            else:  # threlfall: 1 − (1 − exp(−3|v|/v0))/(1 − e⁻³) for |v| ≤ v0
                if not speed[r] <= a:
                    continue
                d = 1.0 - (1.0 - math.exp(3.0 * speed[r] * inv)) / _E3
            d *= mask[r]
            dd += d * d
            dy += d * y[r]
            for c in range(n_cols):
                s_dF[i, c] += d * F[r, c]
        s_dd[i] = dd
        s_dy[i] = dy
    return s_dd, s_dy, s_dF


def dip_sums(kind: str, theta: np.ndarray, speed: np.ndarray, log_speed: np.ndarray, mask: np.ndarray,
             F: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(d·d, d·y, dᵀF) per candidate: (P,), (P,), (P, L).

    Args:
        kind: ``tustin``, ``stribeck`` or ``threlfall``.
        theta: (P, m) the branch's nonlinear parameters (vs | vs, δ | v0).
        speed, log_speed, mask: (n,) |v| > 0, log|v| and the signed branch mask of the rows.
        F: (n, L) design rows; y: (n,) torque rows.
    """
    return _dip_sums(KIND_CODES[kind], np.ascontiguousarray(theta, dtype=float), speed, log_speed, mask,
                     np.ascontiguousarray(F), y)
