"""Starts of a law's dip from a feature of the data: its low-speed friction curve (:func:`dip_start`).

The nested Coulomb fit (the law where its dip has vanished, :func:`vanished_dip`: rigid body, Fv, Fc
and offsets in closed form) leaves, along the motion, the friction it does not explain:
e = (y − ŷ)·sign(q̇). Binned by speed (medians of log-spaced bins from the slowest used row to the
fastest) it is the law's dip above Fc, less what the Coulomb and viscous levels absorbed of it:
a + c·|v| + b·dip(|v|).
Each joint's (and branch's) dip shape — vs and δ (Stribeck), vs (Tustin, a dynamic law's level),
v0 (Threlfall) — is the one of a grid whose least-squares a, b fit that curve best; the start holds
them (the other parameters are solved in closed form for it by the caller). A start, not a fit: a
local solver goes from there, a global one takes it among its first members. On TX40 joint-2-like
logs (δ 0.5–3) it lands within the basin of the optimum where the best of 64 random shapes need not.
"""

from __future__ import annotations

import numpy as np

from frictionid_core.friction import get_model, parameter_base
from frictionid_core.model import IdentificationModel

CURVE_BINS = 24  # log-spaced speed bins of the friction curve
CURVE_MIN_ROWS = 5  # a bin with fewer rows is left out
SCALE_GRID = 40  # speed scales tried, log-spaced over the curve's speeds
DELTA_GRID = (0.5, 0.7, 1.0, 1.4, 2.0, 2.8, 4.0)  # Stribeck exponents tried


def friction_curve(model: IdentificationModel, x: np.ndarray, rows: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(speeds, median excess friction, rows per bin) over the rows ``rows`` (R,) of ``model``
    with the parameters ``x`` (its residual along the motion, binned by speed); None when fewer
    than 3 bins hold CURVE_MIN_ROWS rows."""
    obs = model.obs
    nd = obs.n_samples
    r = model.residuals(x)
    if obs.weight is not None:  # thinned rows are weighted: the friction itself
        r = r / np.tile(obs.weight, len(obs.joints))
    joint = rows // nd
    v = obs.velocity[rows % nd, joint]
    speed, excess = np.abs(v), r[rows] * np.sign(v)
    keep = speed > 0.0
    speed, excess = speed[keep], excess[keep]
    if speed.size < 3 * CURVE_MIN_ROWS or speed.max() <= speed.min():
        return None
    edges = np.geomspace(speed.min(), np.quantile(speed, 0.99) * (1 + 1e-9), CURVE_BINS + 1)
    which = np.clip(np.searchsorted(edges, speed, side="right") - 1, 0, CURVE_BINS - 1)
    centres, medians, counts = [], [], []
    for b in range(CURVE_BINS):
        at = which == b
        if at.sum() >= CURVE_MIN_ROWS:
            centres.append(float(np.sqrt(edges[b] * edges[b + 1])))
            medians.append(float(np.median(excess[at])))
            counts.append(int(at.sum()))
    if len(centres) < 3:
        return None
    return np.array(centres), np.array(medians), np.array(counts, dtype=float)


def best_shape(law: str, speeds: np.ndarray, excess: np.ndarray, counts: np.ndarray, fixed: dict[int, float]
               ) -> tuple[float, ...]:
    """The dip shape (the nonlinear parameters of the law named ``law``) of the grid whose
    a + c·|v| + b·dip fits the curve best (weighted by the rows per bin); ``fixed``: {position in the
    shape: value} held."""
    model = get_model(law)
    n = len(model.law.nonlinear)
    grids = [np.geomspace(speeds.min(), speeds.max(), SCALE_GRID), np.array(DELTA_GRID)][:n]
    grids = [np.array([fixed[p]]) if p in fixed else g for p, g in enumerate(grids)]
    shapes = np.array(np.meshgrid(*grids, indexing="ij")).reshape(n, -1).T  # (S, n)
    params = np.zeros((shapes.shape[0], len(model.names)))
    level = "Fs" if "Fs" in model.names else "Fc"  # the dip's column: Fs·dip, or Fc·(1 − dip) without Fs
    params[:, model.names.index(level)] = 1.0
    params[:, len(model.law.linear):] = shapes
    columns = model.torque(params, speeds)  # (S, bins): dip, or 1 − dip
    w = np.sqrt(counts)
    sse = np.empty(shapes.shape[0])
    for k, col in enumerate(columns):
        A = np.column_stack([np.ones_like(col), speeds, col]) * w[:, None]
        coef, *_ = np.linalg.lstsq(A, excess * w, rcond=None)
        sse[k] = np.sum((A @ coef - excess * w) ** 2)
    return tuple(float(v) for v in shapes[int(np.argmin(sse))])


def vanished_dip(model: IdentificationModel) -> np.ndarray:
    """Nonlinear parameters (k,; the others 0) where the dip has vanished above the slowest used
    speeds: its speed scale at its lower bound, its exponent at its upper one (at its lower one,
    0.3, the dip would reach decades beyond vs): the nested Coulomb model, closely."""
    lo, hi = model.bounds()
    out = np.zeros(model.k)
    for i in model.nonlinear_index:
        out[i] = hi[i] if parameter_base(model.names[i].rpartition("/")[2]) == "delta" else lo[i]
    return out


def dip_start(model: IdentificationModel) -> np.ndarray | None:
    """Parameters (k,) of ``model`` (a law with a dip) with each joint's and branch's dip shape from
    its friction curve (module doc), the other nonlinear ones at their lower bound and fixed ones at
    their values (the linear ones for the caller to solve); None when no curve could be read."""
    law = model.friction.law
    if not law.nonlinear or model.searched_nonlinear_index.size == 0:
        return None
    corner = model.solve_linear(vanished_dip(model)[None])[0][0]
    obs = model.obs
    nd, joints = obs.n_samples, obs.joints
    out = corner.copy()
    found = False
    by_group: dict[tuple[str, str], dict[int, int]] = {}  # (joint, branch) → {position in the shape: index}
    for i in model.nonlinear_index:
        name = model.names[i]
        joint, _, base = name.rpartition("/")
        branch = "_pos" if base.endswith("_pos") else "_neg" if base.endswith("_neg") else ""
        position = law.nonlinear.index(parameter_base(base))
        by_group.setdefault((joint or joints[0], branch), {})[position] = i
    for (joint, branch), index in by_group.items():
        if joint not in joints:
            continue
        j = joints.index(joint)
        rows = j * nd + np.flatnonzero(obs.used[j * nd : (j + 1) * nd])
        v = obs.velocity[rows - j * nd, j]
        rows = rows[v > 0] if branch == "_pos" else rows[v < 0] if branch == "_neg" else rows
        curve = friction_curve(model, corner, rows)
        if curve is None:
            continue
        fixed = {p: model.fixed_values[i] for p, i in index.items() if i in model.fixed_values}
        shape = best_shape(model.friction.name, *curve, fixed)
        for p, i in index.items():
            if i not in model.fixed_values:
                out[i] = shape[p]
        found = True
    return out if found else None
