"""The fit of a dynamic friction law (LuGre, Maxwell-slip): the static part first, then the
pre-sliding part from every row (:func:`fit_dynamic`).

1. *Static part.* The law's sliding limit is the Stribeck law with δ = 2: that law (δ fixed) is
   fitted on the moving rows by the request's solver with variable projection (``ls`` asks for a
   closed form the dip does not have: lm instead), the rigid body, Fv and the offsets in closed
   form: Fc, Fs, vs, Fv.
   On dynamic data this fit is biased (a static law follows the pre-sliding rows after each
   reversal badly): it is a start only, no test of the dip (a dip the data do not support ends
   at speeds below the data's, where it has no effect).
2. *Pre-sliding start.* Each joint's stiffness from a grid of break-away deflections g/(n·k)
   (PRESLIDE_GRID, m or rad) at its level near rest, max(Fc, Fs), σ1 = 0, from two static starts:
   step 1's, and a Coulomb fit of the rows faster than SLIDING_SHARE of each joint's top speed
   (Fs = Fc; the pre-sliding rows after reversals, which a static law fits badly, left out): per
   joint the candidate whose rows fit best.
3. *Every parameter.* Levenberg–Marquardt (trust-region reflective) on every row, standstill and
   reversals included, over every nonlinear parameter of the law (Fc, Fs, vs and the pre-sliding
   ones), the rigid body, Fv and the offsets solved in closed form for each (variable projection).

A refit at finer rates (the dip-refit policy) polishes from the previous point (step 3 only).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import LUGRE_DELTA, get_model, parameter_base
from frictionid_core.identification.linear_case import with_data_bounds
from frictionid_core.identification.settings import SolverOptions
from frictionid_core.identification.solve import Fit, fit_static, solve_model
from frictionid_core.identification.stick import coulomb_fit, coulomb_model, without_rows
from frictionid_core.model import IdentificationModel, Observation, parameter_kind
from frictionid_core.systems import exclude_rows

# Break-away deflections g/(n·k) tried for each joint's start (m or rad): micrometres to centimetres.
PRESLIDE_GRID = np.geomspace(1e-6, 3e-2, 19)
# The law's parameters the static part gives (the others are the pre-sliding ones).
STATIC_KINDS = ("Fv", "Fc", "Fs", "vs")
# Stiffness ratio between consecutive Maxwell-slip elements at the start.
ELEMENT_SPREAD = 4.0
# The second start's Coulomb fit takes the rows faster than this share of each joint's top speed.
SLIDING_SHARE = 0.2
# Reshaped dips of the starts: vs at these shares of each joint's top speed, Fs at FS_START × Fc.
VS_SHARES = (0.01, 0.05)
FS_START = 1.5


def fit_dynamic(model, solver: SolverOptions, progress=None, previous: Fit | None = None) -> Fit:
    """The fit (its parameters and optimiser result) of a
    :class:`~frictionid_core.model.DynamicIdentificationModel` (module doc); ``previous``, the fit
    of a coarser round: polished from there."""
    polish = SolverOptions("lm", solver.seed, calls=solver.calls, varpro=True,
                           options=solver.options.get("polish_options") or {} if solver.method == "hybrid"
                           else solver.options if solver.method == "lm" else {})
    if previous is not None:
        x, res = solve_model(model, polish, progress=progress, start=previous.x)
        return Fit(x, optim=previous.optim.refined(res, "dynamic refit at the finer rates: lm from this point"))
    static, x_static, res_static = static_part(model, solver, progress)
    first = static_start(model, static, x_static)
    start = presliding_start(model, [first, sliding_start(model, static, first)])
    x, res = solve_model(model, polish, progress=progress, start=start)
    how = "every parameter on every row: lm (variable projection) from the static fits and a stiffness grid"
    return Fit(x, optim=res if res_static is None else res_static.refined(res, how))


def static_part(model, solver: SolverOptions, progress=None) -> tuple[IdentificationModel, np.ndarray, object]:
    """(the static model: Stribeck with δ = LUGRE_DELTA on the moving rows, its fit (k,), its
    OptimResult or None)."""
    law = get_model("stribeck", model.friction.asymmetric)
    kinds = set(STATIC_KINDS) | {"delta"}

    def applies(key: str) -> bool:  # the user's values of the rigid body, offsets and the static part
        kind = parameter_kind(key)
        return kind in kinds or kind not in set(model.friction.branch_names) | {"sigma0", "sigma1", "k"}

    static = with_data_bounds(IdentificationModel(
        moving_rows(model.obs), law, model.offset, model.rigid_bounds,
        {k: v for k, v in model.bound_overrides.items() if applies(k)},
        {**{k: v for k, v in model.fixed.items() if applies(k)}, "delta": LUGRE_DELTA}))
    method = replace(solver, varpro=True) if solver.method != "ls" else SolverOptions("lm", solver.seed, varpro=True)
    fit = fit_static(static, method, progress)
    return static, fit.x, fit.optim


def moving_rows(full: Observation) -> Observation:
    """A copy of a full observation with the rows it does not count as moving left out (zeroed)."""
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


def presliding_start(model, starts: list[np.ndarray]) -> np.ndarray:
    """The start of the last stage: candidates from each of ``starts`` (k,) (the static fit's, the
    sliding rows' Coulomb fit's) — the dip as there or reshaped (:func:`_shapes`), the
    pre-sliding parameters at each deflection of PRESLIDE_GRID (:func:`_grid`), all joints alike in
    one candidate — and each joint taking its best candidate of all. User-fixed values are kept."""
    obs = model.obs
    nj, nd = len(obs.joints), obs.n_samples
    candidates = np.vstack([_grid(model, shaped) for x in starts for shaped in _shapes(model, x)])
    lo, hi = model.bounds()
    candidates = np.clip(candidates, lo, hi)
    for i, v in model.fixed_values.items():
        candidates[:, i] = v
    full, _ = model.solve_linear(candidates)
    error = ((obs.y[None] - model.predict(full)) ** 2).reshape(len(candidates), nj, nd).sum(axis=2)
    out = full[int(np.argmin(error.sum(axis=1)))].copy()
    for j in range(nj):
        best = int(np.argmin(error[:, j]))
        out[model.joint_index[j]] = candidates[best, model.joint_index[j]]
    return out


def _shapes(model, x: np.ndarray) -> list[np.ndarray]:
    """``x`` and copies with each branch's dip reshaped: vs at each VS_SHARES of its joint's top
    speed (99th percentile of |q̇|), Fs at FS_START × its Fc (a static fit's dip on dynamic data
    is often wrong: too fast, or below Fc)."""
    obs, names = model.obs, model.names
    used = obs.used.reshape(len(obs.joints), obs.n_samples)
    top = [float(np.quantile(np.abs(obs.velocity[used[j], j]), 0.99)) if used[j].any() else 0.0
           for j in range(len(obs.joints))]
    out = [np.asarray(x, dtype=float)]
    for share in VS_SHARES:
        shaped = out[0].copy()
        for j, row in enumerate(model.joint_index):
            for k in row:
                name = names[k].rsplit("/", 1)[-1]
                if parameter_base(name) == "vs" and top[j] > 0:
                    shaped[k] = share * top[j]
                elif parameter_base(name) == "Fs":
                    shaped[k] = FS_START * shaped[names.index(names[k].replace("/Fs", "/Fc") if "/" in names[k]
                                                              else "Fc" + name[2:])]
        out.append(shaped)
    return out


def _grid(model, x: np.ndarray) -> np.ndarray:
    """(PRESLIDE_GRID.size, k): ``x`` with its pre-sliding parameters at each deflection of the grid."""
    names, n = model.names, model.friction.elements
    candidates = np.repeat(np.asarray(x, dtype=float)[None], PRESLIDE_GRID.size, axis=0)
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
    return candidates


def sliding_start(model, static: IdentificationModel, x: np.ndarray) -> np.ndarray:
    """``x`` (the dynamic model's (k,)) with the rigid body, Fv, Fc and offsets of a Coulomb fit of
    the rows faster than SLIDING_SHARE × each joint's top speed (where the bristles slide: the
    pre-sliding rows after each reversal mislead a static fit), Fs = Fc; ``x`` when that fit fails."""
    obs = static.obs
    used = obs.used.reshape(len(obs.joints), obs.n_samples)
    speed = {j: SLIDING_SHARE * float(np.quantile(np.abs(obs.velocity[used[k], k]), 0.99))
             for k, j in enumerate(obs.joints) if used[k].any()}
    try:
        fit = coulomb_model(static, without_rows(obs, speed))
        values = dict(zip(fit.names, coulomb_fit(fit)))
    except FrictionIdError:
        return x
    out = x.copy()
    for i, name in enumerate(model.names):
        kind, stem = parameter_kind(name), name[: len(name) - len(name.rsplit("/", 1)[-1])]
        source = f"{stem}Fc{name[len(stem) + 2:]}" if kind == "Fs" else name
        if source in values and i not in model.fixed_values:
            out[i] = values[source]
    return out
