"""Fused, compiled population cost of :class:`~frictionid_core.model.IdentificationModel`.

One pass per candidate over the observation rows: the linear terms, the Stribeck/Threlfall dip
added on the rows where its branch is active (compacted once when the model is built), the
squared residual — no (P, R) temporaries. The dip shapes themselves (one exp per active row)
are computed beforehand by numpy's SIMD ``exp`` via ``FrictionModel.dip``. Equal to the
``IdentificationModel.predict``-based cost to rounding (tested).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, fastmath=True)
def batch_sse(params, y, fixed, lin_idx, term_dip, term_sign, dip_start, rows, mask, dip_values):
    """Sum of squared residuals y − ŷ for each row of params (P, k) → (P,).

    Dip d acts on ``rows[dip_start[d]:dip_start[d+1]]`` with signed branch mask ``mask`` and
    shape ``dip_values[p, i]`` (P, total active rows); its weight is Σ term_sign·coefficient
    over the linear terms with ``term_dip == d``.
    """
    n_pop = params.shape[0]
    n_rows, n_lin = fixed.shape
    n_dip = dip_start.size - 1
    out = np.empty(n_pop)
    pred = np.empty(n_rows)
    coef = np.empty(n_lin)
    for p in range(n_pop):
        for l in range(n_lin):
            coef[l] = params[p, lin_idx[l]]
        for r in range(n_rows):
            acc = 0.0
            for l in range(n_lin):
                acc += fixed[r, l] * coef[l]
            pred[r] = acc
        for d in range(n_dip):
            w = 0.0
            for l in range(n_lin):
                if term_dip[l] == d:
                    w += term_sign[l] * coef[l]
            for i in range(dip_start[d], dip_start[d + 1]):
                pred[rows[i]] += w * mask[i] * dip_values[p, i]
        sse = 0.0
        for r in range(n_rows):
            e = y[r] - pred[r]
            sse += e * e
        out[p] = sse
    return out
