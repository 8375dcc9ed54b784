"""Fused, compiled population cost of :class:`~frictionid_core.model.IdentificationModel`.

The linear part of every candidate's prediction is one BLAS product; this kernel then adds
the Stribeck/Threlfall dip on the rows where its branch is active (compacted once when the
model is built) and sums the squared residuals, one pass per candidate. The dip shapes (one
exp per active row) are computed beforehand by numpy's SIMD ``exp`` via ``FrictionModel.dip``. Equal to the
``IdentificationModel.predict``-based cost to rounding (tested).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, fastmath=True)
def batch_sse(pred, y, coef, term_dip, term_sign, dip_start, rows, mask, dip_values):
    """Sum of squared residuals y − ŷ for each candidate → (P,).

    ``pred`` (P, R) holds the linear part (coefficients (P, L) @ fixed columnsᵀ, by BLAS) and is
    completed in place: dip d adds Σ term_sign·coefficient (over the terms with ``term_dip == d``)
    × ``mask`` × ``dip_values[p, i]`` on ``rows[dip_start[d]:dip_start[d+1]]``.
    """
    n_pop, n_rows = pred.shape
    n_lin = coef.shape[1]
    n_dip = dip_start.size - 1
    out = np.empty(n_pop)
    for p in range(n_pop):
        for d in range(n_dip):
            w = 0.0
            for l in range(n_lin):
                if term_dip[l] == d:
                    w += term_sign[l] * coef[p, l]
            for i in range(dip_start[d], dip_start[d + 1]):
                pred[p, rows[i]] += w * mask[i] * dip_values[p, i]
        sse = 0.0
        for r in range(n_rows):
            e = y[r] - pred[p, r]
            sse += e * e
        out[p] = sse
    return out
