"""The fit of a dynamic friction law (LuGre, Maxwell-slip): the static part first, then the
pre-sliding part from every row (:func:`fit_dynamic`).

1. *Static part.* The law's sliding limit is the Stribeck law with δ = 2: that law (δ fixed) is
   fitted on the moving rows by the request's solver (``ls`` asks for a closed form the dip does
   not have: variable projection with lm instead), with the rigid body, Fv and the offsets in
   closed form: Fc, Fs, vs, Fv.
   When that dip does not beat its Coulomb case on held-back rows (as for static laws), Fs = Fc
   and vs at its lower bound are held: the level is Fc (Dahl's law with one Maxwell-slip element).
2. *Pre-sliding start.* Each joint's stiffness from a grid of break-away deflections g/(n·k)
   (PRESLIDE_GRID, m or rad) at its level near rest, max(Fc, Fs), σ1 = 0: per joint the value
   whose rows fit best.
3. *Every parameter.* Levenberg–Marquardt (trust-region reflective) on every row, standstill and
   reversals included, over every nonlinear parameter of the law (Fc, Fs, vs and the pre-sliding
   ones), the rigid body, Fv and the offsets solved in closed form for each (variable projection).

A refit at finer rates (the dip-refit policy) polishes from the previous point (step 3 only).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from frictionid_core.friction import get_model
from frictionid_core.friction.laws import LUGRE_DELTA, parameter_base
from frictionid_core.identification.linear_case import (
    holdout_comparison,
    linear_special_case,
    special_case_parameters,
    with_data_bounds,
)
from frictionid_core.identification.settings import SolverOptions
from frictionid_core.identification_model import IdentificationModel
from frictionid_core.observation import Observation
from frictionid_core.parameter_names import parameter_kind

# Break-away deflections g/(n·k) tried for each joint's start (m or rad): micrometres to centimetres.
PRESLIDE_GRID = np.geomspace(1e-6, 3e-2, 19)
# The law's parameters the static part gives (the others are the pre-sliding ones).
STATIC_KINDS = ("Fv", "Fc", "Fs", "vs")
# Stiffness ratio between consecutive Maxwell-slip elements at the start.
ELEMENT_SPREAD = 4.0


def fit_dynamic(model, solver: SolverOptions, progress=None, previous=None) -> tuple:
    """The fit (x (k,), None, None, OptimResult) of a
    :class:`~frictionid_core.dynamic_model.DynamicIdentificationModel` (module doc); ``previous``
    (x, OptimResult) of a coarser round: polished from there."""
    from frictionid_core.identification.solve import solve_model

    polish = SolverOptions("lm", solver.seed, calls=solver.calls, varpro=True,
                           options=solver.options.get("polish_options") or {} if solver.method == "hybrid"
                           else solver.options if solver.method == "lm" else {})
    if previous is not None:
        x, res = solve_model(model, polish, progress=progress, start=previous[0])
        return x, None, None, previous[1].refined(res, "dynamic refit at the finer rates: lm from this point")
    static, x_static, res_static = static_part(model, solver, progress)
    searched, how = model, "pre-sliding parameters on every row: lm (variable projection) from the static fit"
    holdout = holdout_comparison(static, x_static, polish)
    if holdout.get("beats_linear") is False:  # no dip: Fs and vs would wander; held without effect
        special, x_special = linear_special_case(static)
        x_static = special_case_parameters(static, x_static, special, x_special)
        lo, _ = static.bounds()
        held = {n: float(lo[i] if parameter_kind(n) == "vs" else x_static[i]) for i, n in enumerate(static.names)
                if parameter_kind(n) in ("vs", "Fs") and i not in static.fixed_values}
        searched = replace(model, fixed={**model.fixed, **held})
        how += (f" (the static dip does not beat Coulomb on held-back rows: {holdout['law_relerr_pct']:.4g} % vs "
                f"{holdout['linear_relerr_pct']:.4g} %; Fs = Fc and vs at its lower bound held)")
    start = presliding_start(searched, static_start(searched, static, x_static))
    x, res = solve_model(searched, polish, progress=progress, start=start)
    return x, None, None, res if res_static is None else res_static.refined(res, how + " and a stiffness grid")


def static_part(model, solver: SolverOptions, progress=None) -> tuple[IdentificationModel, np.ndarray, object]:
    """(the static model: Stribeck with δ = LUGRE_DELTA on the moving rows, its fit (k,), its
    OptimResult or None)."""
    from frictionid_core.identification.solve import fit_model

    law = get_model("stribeck", model.friction.asymmetric)
    kinds = set(STATIC_KINDS) | {"delta"}

    def applies(key: str) -> bool:  # the user's values of the rigid body, offsets and the static part
        kind = parameter_kind(key)
        return kind in kinds or kind not in set(model.friction.branch_names) | {"sigma0", "sigma1", "k"}

    static = with_data_bounds(IdentificationModel(
        moving_rows(model.obs), law, model.offset, model.rigid_bounds,
        {k: v for k, v in model.bound_overrides.items() if applies(k)},
        {**{k: v for k, v in model.fixed.items() if applies(k)}, "delta": LUGRE_DELTA}))
    method = solver if solver.method != "ls" else SolverOptions("lm", solver.seed, varpro=True)
    if method.varpro is None:
        method = SolverOptions(method.method, method.seed, method.pop, method.generations, method.calls, True,
                               method.warm_start, method.options)
    x, _, _, res = fit_model(static, method, progress)
    return static, x, res


def moving_rows(full: Observation) -> Observation:
    """A copy of a full observation with the rows it does not count as moving left out (zeroed)."""
    from frictionid_core.identification.stick import without_rows
    from frictionid_core.systems.system import exclude_rows

    obs = without_rows(full, {})
    nd = obs.n_samples
    if full.moving is not None:
        exclude_rows(obs, ~full.moving.reshape(len(obs.joints), nd).T)
    obs.full, obs.moving = None, None
    return obs


def static_start(model, static: IdentificationModel, x_static: np.ndarray) -> np.ndarray:
    """The dynamic model's parameters (k,) from the static fit: every shared name its value (the
    pre-sliding ones at 0)."""
    values = dict(zip(static.names, x_static))
    return np.array([values.get(n, 0.0) for n in model.names], dtype=float)


def presliding_start(model, x: np.ndarray) -> np.ndarray:
    """``x`` with each joint's pre-sliding parameters set from PRESLIDE_GRID (module doc): all
    joints on one deflection per candidate, each joint then taking its best; σ1 at 0, the
    Maxwell-slip stiffnesses spread by ELEMENT_SPREAD. User-fixed values are kept."""
    obs, names = model.obs, model.names
    nj, nd = len(obs.joints), obs.n_samples
    candidates = np.repeat(x[None], PRESLIDE_GRID.size, axis=0)
    n = model.friction.elements
    for k in model.joint_index.ravel():
        joint, _, name = names[k].rpartition("/")
        suffix = name[-4:] if name.endswith(("_pos", "_neg")) else ""
        kind = parameter_base(name)
        stem = f"{joint}/" if joint else ""
        level = max(float(x[names.index(f"{stem}Fc{suffix}")]), float(x[names.index(f"{stem}Fs{suffix}")]), 1e-9)
        if kind == "sigma0":
            candidates[:, k] = level / PRESLIDE_GRID
        elif kind == "sigma1":
            candidates[:, k] = 0.0
        elif kind == "k":
            element = int(name.removesuffix(suffix)[1:]) - 1
            spread = ELEMENT_SPREAD ** ((n - 1) / 2.0 - element)  # geometric, centred on the grid's value
            candidates[:, k] = level * spread / (n * PRESLIDE_GRID)
    lo, hi = model.bounds()
    candidates = np.clip(candidates, lo, hi)
    for i, v in model.fixed_values.items():
        candidates[:, i] = v
    full, _ = model.solve_linear(candidates)
    error = ((obs.y[None] - model.predict(full)) ** 2).reshape(PRESLIDE_GRID.size, nj, nd).sum(axis=2)
    out = full[0].copy()
    for j in range(nj):
        best = int(np.argmin(error[:, j]))
        out[model.joint_index[j]] = candidates[best, model.joint_index[j]]
    return out
