"""A law against its linear special case (Coulomb): the Coulomb model nested in a law and its
closed-form fit, the bounds the data ground from it (:func:`data_bounds`: vs within the used speeds,
Fs within a factor of its Fc, a dynamic law's levels within a factor of the joint's largest torque),
the comparison on held-back rows and the fallback to it."""

from __future__ import annotations

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import DEFAULT_BOUNDS, get_model
from frictionid_core.identification.settings import SolverOptions
from frictionid_core.identification.solve import is_closed_form, solve_model
from frictionid_core.model import IdentificationModel, parameter_kind

# Fs ≤ FS_FACTOR × the Coulomb special case's Fc of its joint and branch: a static friction many
# times the sliding level fits something else (a few rows near standstill, a transient).
FS_FACTOR = 3.0
# … where that Fc is below this share of the joint's largest |torque|, FS_FACTOR × that share.
FS_FLOOR_SHARE = 0.01
# A dynamic law's sliding levels (Fc, Fs) ≤ LEVEL_FACTOR × its joint's largest |torque|: a level the
# joint never applied is one it never overcame. A joint whose torques the fit hardly weighs (a wrist
# beside a shoulder) otherwise drifts there: a panda wrist of 0.1 N·m fitted Fs = 82 N·m (its
# bristles at rest 3500 rad deflected, a spring), which validated at 1e5 %.
LEVEL_FACTOR = 2.0
# Hold-out of the comparison with the linear special case: the instants split into HOLDOUT_BLOCKS
# contiguous blocks, every HOLDOUT_EVERY-th held back (a quarter of the log, spread over it).
HOLDOUT_BLOCKS = 20
HOLDOUT_EVERY = 4
# The law beats its linear case only when its held-back error is more than this share of the linear
# case's lower: on Coulomb data the two differ by ~1e-4 of it either way (a tie, no evidence).
HOLDOUT_MARGIN = 0.005


def linear_special_case(model: IdentificationModel) -> tuple[IdentificationModel, np.ndarray]:
    """(the Coulomb model nested in ``model``'s law: the same rows, rigid body, offsets, fixed
    values and bounds of the parameters it shares; its closed-form solution (k_c,))."""
    coulomb = get_model("coulomb", model.friction.asymmetric)
    names = {n for n in model.names if parameter_kind(n) not in ("Fs", *model.friction.law.nonlinear)}
    fixed = {model.names[i]: v for i, v in model.fixed_values.items() if model.names[i] in names}
    bounds = {model.names[i]: b for i, b in model.user_bounds.items() if model.names[i] in names}
    special = IdentificationModel(model.obs, coulomb, model.offset, model.rigid_bounds, bounds, fixed,
                                  physical=model.physical)
    return special, special.fit_linear()[0]


def special_case_parameters(model: IdentificationModel, x: np.ndarray, special: IdentificationModel,
                            x_special: np.ndarray) -> np.ndarray:
    """``model``'s parameters (k,) that predict what the Coulomb ``special`` case's ``x_special``
    does: its values by name, Fs = Fc (the dip's height 0: tustin, stribeck; vs and δ of ``x``
    kept, without effect), v0 at its lower bound (threlfall: below every used speed, no dip)."""
    value = dict(zip(special.names, x_special))
    lo, _ = model.bounds()
    out = np.array(x, dtype=float)
    for i, name in enumerate(model.names):
        base = name.rsplit("/", 1)[-1]
        if name in value:
            out[i] = value[name]
        elif base.startswith("Fs"):
            out[i] = value[name[: len(name) - len(base)] + "Fc" + base[2:]]
        elif base.startswith("v0") and i not in model.fixed_values:
            out[i] = lo[i]
    return out


def data_bounds(model: IdentificationModel) -> dict[str, tuple[float, float]]:
    """Bounds of a nonlinear law grounded in the data of ``model`` (docs/cli.md#constraints): vs
    and v0 within the used speeds of their joint [slowest, fastest], and within the law's default
    range (:data:`~frictionid_core.friction.DEFAULT_BOUNDS`: a search over decades of speed needs
    a cap) where the two overlap; Fs ≤ FS_FACTOR × the Coulomb
    special case's Fc of its joint and branch (at least FS_FACTOR × FS_FLOOR_SHARE × the joint's
    largest |torque|; not for a dynamic law, whose pre-sliding rows bias that Fc); a dynamic law's
    Fc and Fs ≤ LEVEL_FACTOR × the joint's largest |torque| on the used rows. {} for a linear law."""
    if model.is_linear:
        return {}
    obs = model.obs
    nd, nj = obs.n_samples, len(obs.joints)
    special = x_special = None
    out = {}
    y = obs.unweighted().y  # torques in N·m or N
    for j, joint in enumerate(obs.joints):
        rows = slice(j * nd, (j + 1) * nd)
        speed = np.abs(obs.velocity[obs.used[rows], j])
        speed = speed[speed > 0.0]
        prefix = f"{joint}/" if nj > 1 else ""
        level_cap = LEVEL_FACTOR * float(np.max(np.abs(y[rows][obs.used[rows]]), initial=0.0))
        for name in model.friction.names:
            base = name.removesuffix("_pos").removesuffix("_neg")
            if base in ("vs", "v0") and speed.size and speed.max() > speed.min():
                lo, hi = DEFAULT_BOUNDS[base]
                out[prefix + name] = (max(float(speed.min()), lo), min(float(speed.max()), hi))
                if not out[prefix + name][0] < out[prefix + name][1]:  # the law's range misses the data's
                    out[prefix + name] = (float(speed.min()), float(speed.max()))
            elif base == "Fs" and not model.friction.is_dynamic:  # a static fit misjudges a dynamic law's Fc
                if special is None:
                    special, x_special = linear_special_case(model)
                fc = float(x_special[special.names.index(prefix + "Fc" + name[2:])])
                floor = FS_FLOOR_SHARE * float(np.max(np.abs(y[rows]), initial=0.0))
                out[prefix + name] = (0.0, FS_FACTOR * max(fc, floor, np.finfo(float).tiny))
            elif base in ("Fc", "Fs") and model.friction.is_dynamic:
                lo, hi = DEFAULT_BOUNDS[base]
                if lo < level_cap < hi:
                    out[prefix + name] = (lo, level_cap)
    return out


def with_data_bounds(model: IdentificationModel) -> IdentificationModel:
    """``model`` with its :func:`data_bounds` (the model itself for a linear law)."""
    bounds = data_bounds(model)
    if not bounds:
        return model
    return type(model)(model.obs, model.friction, model.offset, model.rigid_bounds, model.bound_overrides,
                       model.fixed, bounds, model.physical)


def holdout_comparison(model: IdentificationModel, x: np.ndarray, solver: SolverOptions) -> dict:
    """The law of ``model`` against its linear special case on held-back rows: both fitted again
    on the other rows (the law by an lm polish from ``x``, or in closed form when nothing is
    searched; the Coulomb case in closed form), their relative errors [%] on the held-back rows;
    the law beats it when its error is more than HOLDOUT_MARGIN (0.5 %) of the linear case's lower.

    Returns {held_back_rows, law_relerr_pct, linear_relerr_pct, beats_linear}, or {skipped: why}
    when the training rows cannot be fitted (e.g. a joint that no longer moves both ways)."""
    nd = model.obs.n_samples
    held = (np.arange(nd) * HOLDOUT_BLOCKS // max(nd, 1)) % HOLDOUT_EVERY == HOLDOUT_EVERY - 1
    special, _ = linear_special_case(model)
    try:
        train = model.restricted(~held)
        if is_closed_form(train, solver):
            x_law = train.fit_linear()[0]
        else:
            polish = SolverOptions("lm", solver.seed, calls=solver.calls, varpro=solver.varpro)
            x_law = solve_model(train, polish, start=x)[0]
        x_lin = special.restricted(~held).fit_linear()[0]
    except FrictionIdError as exc:
        return {"skipped": str(exc)}
    rows = np.tile(held, len(model.obs.joints)) & model.obs.used
    scale = float(np.linalg.norm(model.obs.y[rows])) or 1.0
    law = float(np.linalg.norm(model.residuals(x_law)[rows]))
    linear = float(np.linalg.norm(special.residuals(x_lin)[rows]))
    return {"held_back_rows": int(rows.sum()), "law_relerr_pct": 100.0 * law / scale,
            "linear_relerr_pct": 100.0 * linear / scale, "beats_linear": bool(law < (1.0 - HOLDOUT_MARGIN) * linear)}


def linear_fallback(model: IdentificationModel, x: np.ndarray) -> tuple[np.ndarray, dict[str, float], float]:
    """(``model``'s parameters at its linear special case (Coulomb) fitted in closed form, their
    σ (Fs: Fc's; the dip's shape parameters: NaN, they have no effect), the condition number)."""
    special, x_special = linear_special_case(model)
    _, std_special, cond = special.fit_linear()
    out = special_case_parameters(model, x, special, x_special)
    std = {}
    for i, name in enumerate(model.names):
        base = name.rsplit("/", 1)[-1]
        if name in std_special:
            std[name] = std_special[name]
        elif base.startswith("Fs"):
            std[name] = std_special.get(name[: len(name) - len(base)] + "Fc" + base[2:], float("nan"))
        else:
            std[name] = 0.0 if i in model.fixed_values else float("nan")
    return out, std, cond
