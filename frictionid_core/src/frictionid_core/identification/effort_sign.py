"""Efforts logged with the opposite sign to the model's joint axis (:func:`checked_effort_sign`).

A driver may report a joint's effort with the sign opposite to its URDF axis (the real TIAGo's
``arm_3_joint`` and ``arm_4_joint``). Fitted as logged, that joint's friction and rotor inertia are
pulled below 0 (the sign constraints hold them there), a robot's shared link parameters bend to
serve one row against the others, and its torque is badly predicted; no bound or prior mends it.

The check, joint by joint, on every fit (any system; one source or several; a joint-side log or a
motor-side drive, whose recorded efforts are the motors'):

1. **Screen** (:func:`screened_rows`): on the linear columns of the as-logged fit's model (its
   Coulomb case: rigid body, Fv, Fc, offsets, on the same rows, the same held directions), each
   row's effort is negated alone and the constrained least squares solved again — a cheap closed
   form, as the negation changes only Fᵀy. A row, or a pair of rows, is suspect when negating it
   leaves each of its rows at most :data:`CLEARLY_BETTER` of its relative error and the whole fit
   a smaller one (a pair: two reversed joints of one arm may each fit the links they share only
   beside the other); the suspect that fits the whole best is taken and the others screened again
   with it negated, until none is left. The test rests on what a sign cannot carry:
   friction levels, masses and inertias cannot be negative, and a robot's links are shared by its
   rows; gravity, free in sign, fits either way, so a gravity-dominated joint is judged by its
   friction and inertia and by the other rows its links enter.
2. **Confirmation**: the full fit again with the suspects' efforts negated (a drive with
   ``effort_scale`` −1 there). Each negated joint must keep at most CLEARLY_BETTER of its relative
   error and the whole fit must improve; a joint that fails is given back its logged sign and the
   rest fitted again.

A joint whose effort follows its axis fits far worse negated (its friction and inertia would have
to go negative), so it is never a suspect: a close call keeps the logged sign. ``effort_sign:
auto`` returns the negated fit (its drive holds the signs: ``validate`` and the node's screen read
them); ``as-logged`` keeps the log's signs and says what negating would give.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from frictionid_core.drive import drive_from_dict, load_drive
from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_core.identification.request import IdentifyRequest
from frictionid_core.identification.result import IdentifyResult
from frictionid_core.model import IdentificationModel, parameter_kind

# A negated effort is taken when it leaves its joint at most this share of its relative error (and
# the whole fit a smaller error): a reversed joint's error falls from its friction's and inertia's
# share of its torque to its noise (14.7 → 1.04 % on a gravity-loaded UR5 shoulder at 1 % noise; TIAGo arm_3,
# arm_4: 62.3 → 26.8, 51.3 → 23.2 %), a
# right one's rises.
CLEARLY_BETTER = 0.7
_LEVELS = ("Fv", "Fc")  # the friction levels whose signs say the effort runs against the motion


def friction_levels(result: IdentifyResult, row: str) -> list[float]:
    """The viscous and Coulomb levels (each branch) of the friction row ``row`` (a data joint, or a
    motor ``motor_<k>``): ``<row>/Fv``…, or ``Fv``… in a fit of one row (names without prefix)."""
    prefixed = [v for name, v in result.params.items()
                if name.startswith(f"{row}/") and parameter_kind(name) in _LEVELS]
    if prefixed:
        return prefixed
    return [v for name, v in result.params.items() if "/" not in name and "." not in name
            and parameter_kind(name) in _LEVELS]


def negative_friction_rows(result: IdentifyResult, rows: list[str]) -> list[str]:
    """The friction ``rows`` whose viscous and Coulomb levels (each branch) are all ≤ 0: held at
    the sign constraint's 0, or negative where the user's bounds allow it."""
    return [row for row in rows if (levels := friction_levels(result, row)) and all(v <= 0.0 for v in levels)]


def negated_drive(request: IdentifyRequest, joints: list[str], negate: list[str]) -> dict | None:
    """The drive keys of ``request``'s drive (none: a joint-side drive of ``joints``, the log's
    joints as the model names them) with the recorded efforts of the model joints ``negate``
    negated (a motor-side drive: the efforts of their motors); None when one of them is not in it."""
    drive = request.drive
    if drive is None:
        keys = {"name": "effort signs", "joints": list(joints), "side": "joint"}
    else:
        loaded = load_drive(drive) if isinstance(drive, str) else drive_from_dict(drive, "the request's drive")
        keys = loaded.to_dict()
    if not set(negate) <= set(keys["joints"]):
        return None
    scale = list(keys.get("effort_scale") or [1.0] * len(keys["joints"]))
    keys["effort_scale"] = [-s if j in negate else s for j, s in zip(keys["joints"], scale)]
    return keys


@dataclass
class _Rows:
    """The row blocks of a model for the screen: per block its Gram pieces on the used rows."""

    names: list[str]  # the model's rows (joints, or motors)
    gram: np.ndarray  # (J, L, L) XₖᵀXₖ
    rhs: np.ndarray  # (J, L) Xₖᵀyₖ
    power: np.ndarray  # (J,) yₖᵀyₖ


def screened_rows(model: IdentificationModel, candidates: list[str]) -> list[str]:
    """The rows of ``model`` (among ``candidates``) whose effort the screen finds reversed (see the
    module doc, step 1), in the order found."""
    linear = _coulomb_case(model)
    if linear is None:
        return []
    rows = _row_blocks(linear)
    signs = np.ones(len(rows.names))
    errors, total = _errors(linear, rows, signs)
    found: list[str] = []
    open_rows = [k for k, name in enumerate(rows.names) if name in candidates and rows.power[k] > 0]
    while open_rows:
        best = None
        # one row, or two at once: two reversed rows of one arm may each fit its links only beside the other
        for move in [(k,) for k in open_rows] + [(a, b) for i, a in enumerate(open_rows) for b in open_rows[i + 1:]]:
            trial = signs.copy()
            trial[list(move)] = -1.0
            e, t = _errors(linear, rows, trial)
            if t < total and all(e[k] <= CLEARLY_BETTER * errors[k] for k in move) and (best is None or t < best[2]):
                best = (move, e, t, trial)
        if best is None:
            break
        move, errors, total, signs = best
        found += [rows.names[k] for k in move]
        open_rows = [k for k in open_rows if k not in move]
    return found


def _coulomb_case(model: IdentificationModel) -> IdentificationModel | None:
    """The Coulomb case of ``model`` on its observation (its rigid body, Fv, Fc and offsets, the
    same bounds and held values where they name its parameters); None when it cannot be built."""
    law = get_model("coulomb", model.friction.asymmetric)
    try:
        return IdentificationModel(model.obs, law, model.offset, model.rigid_bounds, model.bound_overrides,
                                   model.fixed)
    except FrictionIdError:  # a value or bound of a parameter the Coulomb case lacks (vs, Fs, …)
        try:
            names = set(IdentificationModel(model.obs, law, model.offset).names)
            return IdentificationModel(model.obs, law, model.offset, model.rigid_bounds,
                                       {k: v for k, v in model.bound_overrides.items() if k in names},
                                       {k: v for k, v in model.fixed.items() if k in names})
        except FrictionIdError:
            return None


def _row_blocks(model: IdentificationModel) -> _Rows:
    X, y, used, nd = model.design(), model.obs.y, model.obs.used, model.obs.n_samples
    names = list(model.obs.joints)
    L = X.shape[1]
    gram, rhs, power = np.zeros((len(names), L, L)), np.zeros((len(names), L)), np.zeros(len(names))
    for k in range(len(names)):
        rows = slice(k * nd, (k + 1) * nd)
        keep = used[rows]
        Xk, yk = X[rows][keep], y[rows][keep]
        gram[k], rhs[k], power[k] = Xk.T @ Xk, Xk.T @ yk, yk @ yk
    return _Rows(names, gram, rhs, power)


def _errors(model: IdentificationModel, rows: _Rows, signs: np.ndarray) -> tuple[np.ndarray, float]:
    """(relative error of each row block, of all) of the constrained least squares of the rows with
    their efforts multiplied by ``signs``."""
    c = model.solve_normal(rows.gram.sum(axis=0), signs @ rows.rhs)
    residual = np.maximum(rows.power - 2.0 * signs * (rows.rhs @ c) + np.einsum("l,klm,m->k", c, rows.gram, c), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        per_row = np.sqrt(residual / rows.power)
    return per_row, float(np.sqrt(residual.sum() / rows.power.sum()))


def checked_effort_sign(fit, series, request: IdentifyRequest, result: IdentifyResult, joints: list[str],
                        model: IdentificationModel | None = None) -> IdentifyResult:
    """``result`` (the fit of ``request`` on ``series`` as logged), or, when negating some joints'
    efforts fits them and the whole clearly better (see the module doc), the negated fit
    (``auto``) or ``result`` with a warning saying so (``as-logged``). ``fit(series, request)``
    fits; ``joints``: the logged joints (model names); ``model``: the as-logged fit's model (None:
    no screen, only the warning for friction at or below 0)."""
    if model is None:
        return result
    obs = model.obs
    data = list(obs.torque_joints)  # the data joint behind each row (a motor's own joint)
    channel = {row: request.joint_map.get(d, d) for row, d in zip(obs.joints, data)}
    metric_joint = dict(zip(obs.joints, data))
    drive = negated_drive(request, joints, [])  # the channels a drive can negate
    negatable = [row for row in obs.joints if drive is not None and channel[row] in drive["joints"]]
    negative = negative_friction_rows(result, list(obs.joints))
    negate = screened_rows(model, negatable)
    trial, tried = None, {}  # {row: (relerr as logged, negated)} of every suspect the full fit tried
    while negate:
        keys = negated_drive(request, joints, [channel[r] for r in negate])
        try:
            trial = fit(series, replace(request, drive=keys, effort_sign="as-logged"))
        except FrictionIdError:  # the negated data cannot be fitted (an absurd fit): the log's signs
            negate = []
            break
        tried.update({r: _relerrs(result, trial, metric_joint[r]) for r in negate})
        failing = [r for r in negate if not _clearly_better(result, trial, metric_joint[r])]
        if not failing:
            if trial.metrics["relerr_pct"] < result.metrics["relerr_pct"]:
                break
            negate = []
        negate = [r for r in negate if r not in failing]
    if not negate:
        return _kept(result, negative, tried, metric_joint)
    before = {r: result.metrics["per_joint"][metric_joint[r]]["relerr_pct"] for r in negate}
    after = {r: trial.metrics["per_joint"][metric_joint[r]]["relerr_pct"] for r in negate}
    errors = ", ".join(f"{metric_joint[r]} {before[r]:.3g} → {after[r]:.3g} %" for r in negate)
    named = [metric_joint[r] for r in negate]
    scales = ", ".join(f"{v:g}" for v in keys["effort_scale"])
    yaml = f"joints: [{', '.join(keys['joints'])}], effort_scale: [{scales}]"
    whole = f"the whole fit {result.metrics['relerr_pct']:.3g} → {trial.metrics['relerr_pct']:.3g} %"
    if request.effort_sign == "auto":
        return replace(trial, request=request, warnings=[(
            f"{_efforts(named, 'is', 'are')} logged with the sign opposite to the model's joint axes: negated "
            f"{'it fits' if len(named) == 1 else 'each fits'} clearly better (relerr {errors}; {whole}), so this fit "
            f"negates {'it' if len(named) == 1 else 'them'} (the result's drive: {yaml}; validate reads it from "
            "there, a node needs it in its drive_file); --effort-sign as-logged keeps the log's signs"),
            *trial.warnings])
    return replace(result, warnings=[*result.warnings, (
        f"{_efforts(named, 'seems', 'seem')} logged with the sign opposite to the model's joint axes: negated "
        f"{'it fits' if len(named) == 1 else 'each fits'} clearly better (relerr {errors}; {whole}); a drive with "
        f"{yaml} (or --effort-sign auto) fits {'it' if len(named) == 1 else 'them'} so")])


def _clearly_better(result: IdentifyResult, trial: IdentifyResult, joint: str) -> bool:
    """``joint`` negated in ``trial``: at most CLEARLY_BETTER of its relative error in ``result``."""
    before, after = _relerrs(result, trial, joint)
    return after <= CLEARLY_BETTER * before


def _relerrs(result: IdentifyResult, trial: IdentifyResult, joint: str) -> tuple[float, float]:
    """(relative error of ``joint`` in ``result``, in ``trial``) %."""
    return (result.metrics["per_joint"][joint]["relerr_pct"], trial.metrics["per_joint"][joint]["relerr_pct"])


def _kept(result: IdentifyResult, negative: list[str], tried: dict[str, tuple[float, float]],
          metric_joint: dict[str, str]) -> IdentifyResult:
    """``result`` as logged, with a warning for the rows whose friction ends at or below 0
    (``negative``) and the screen's suspects the full fit did not confirm (``tried``: their
    relative errors as logged and negated): negating does not clearly help."""
    rows = list(dict.fromkeys([*negative, *tried]))
    if not rows:
        return result
    low = [metric_joint[r] for r in negative]
    head = (f"friction of {', '.join(low)} at or below 0: {'its effort does' if len(low) == 1 else 'their efforts do'} "
            "not oppose the motion as the model expects" if low else "")
    if tried:
        errors = ", ".join(f"{metric_joint[r]} {a:.3g} → {b:.3g} %" for r, (a, b) in tried.items())
        tail = f"negating {', '.join(metric_joint[r] for r in tried)} does not fit clearly better (relerr {errors})"
    else:
        tail = f"negating {'it does not fit it' if len(low) == 1 else 'them does not fit them'} clearly better"
    return replace(result, warnings=[*result.warnings, (
        f"{head + ', and ' if head else ''}{tail}: the log's signs are kept; check the driver's effort units and the "
        "model")])


def _efforts(joints: list[str], one: str, several: str) -> str:
    """"the effort of a is" / "the efforts of a, b are" (the verbs given)."""
    return f"the effort of {joints[0]} {one}" if len(joints) == 1 else f"the efforts of {', '.join(joints)} {several}"
