"""A dynamic law's rates: the position cut-off (and the decimation that goes with it) at which the
fitted law itself predicts the effort best (:func:`presliding_changes`).

The pre-processing rule picks each joint's cut-off as the lowest whose filtered q̈, q̇ and sign(q̇)
predict its effort within PREDICTION_TOLERANCE of the best — with a Coulomb model. Where the
friction has pre-sliding, a Coulomb model misses every reversal and dwell by far more than what a
cut-off changes, so the rule settles on its lowest cut-off; there the filter rounds what a
dynamic law is most sensitive to — the last hundred micro-radians before a stop and after a
reversal, the acceleration where it changes fast — and the law's all-row error stays several
times its noise floor (synthetic LuGre joints at 1 kHz: 4.9 % at the rule's 10 Hz, 0.53 % at 40 Hz,
the floor 0.50 %). The same criterion with the law itself decides instead: after a fit, each
candidate cut-off (the rule's grid upwards, at most MAX_CUTOFF_SHARE × fs, the decimation then
chosen by the rule for it) rebuilds the observation, the fit's nonlinear parameters predict the
effort with the linear ones solved in closed form (upwards until no joint predicts better by more
than PREDICTION_TOLERANCE), and each joint takes the lowest candidate whose RMS residual lies within
PREDICTION_TOLERANCE of its best. Position noise raised with the cut-off
shows in that residual (through J·q̈, Fv·q̇ and σ1·ż; the states' travel passes through a play that
noise does not move: :mod:`frictionid_core.preprocess.travel`), so the choice stops where it costs.

The same choice is made again on other data with a result's parameters (:func:`presliding_model`,
for ``validate``): the rule's cut-off of those data, then the law's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from frictionid_core.model import IdentificationModel
from frictionid_core.preprocess import (
    CUTOFFS_PER_DECADE,
    MAX_CUTOFF_SHARE,
    PREDICTION_TOLERANCE,
    Preprocessing,
    rule_decimation,
)

# Candidates: the current cut-off × the rule's grid ratio (10^(1/6)) to the power 0 … CANDIDATES − 1.
CANDIDATES = 7


def candidate_cutoffs(model: IdentificationModel) -> list[dict[str, float]]:
    """The cut-offs ({data joint: Hz}) tried for ``model`` (a dynamic law's, at its current settings):
    each joint's current one times the grid's ratio to the powers 0 … CANDIDATES − 1, at most
    MAX_CUTOFF_SHARE × fs; duplicates dropped."""
    pre = model.obs.preprocessing
    fs = model.obs.report["sample_rate_hz"]
    joints = list(model.obs.data_joints or model.obs.joints)
    base = pre.cutoff_hz if isinstance(pre.cutoff_hz, dict) else dict.fromkeys(joints, float(pre.cutoff_hz))
    out: list[dict[str, float]] = []
    for k in range(CANDIDATES):
        factor = 10.0 ** (k / CUTOFFS_PER_DECADE)
        cut = {j: float(min(c * factor, MAX_CUTOFF_SHARE * fs)) for j, c in base.items()}
        if not out or any(cut[j] > out[-1][j] * (1 + 1e-9) for j in cut):
            out.append(cut)
    return out


def joint_rms(model: IdentificationModel, x: np.ndarray) -> np.ndarray:
    """(J,) each row joint's RMS residual of ``model`` with the nonlinear parameters of ``x`` (k,)
    and the linear ones solved in closed form, over its used rows."""
    full, _ = model.solve_linear(np.asarray(x, dtype=float)[None])
    obs = model.obs
    nj, nd = len(obs.joints), obs.n_samples
    r = (obs.y - model.predict(full[0])).reshape(nj, nd)
    used = obs.used.reshape(nj, nd)
    return np.sqrt(np.sum(np.where(used, r, 0.0) ** 2, axis=1) / np.maximum(used.sum(axis=1), 1))


def presliding_changes(model: IdentificationModel, x: np.ndarray, settings: Preprocessing,
                       rebuild: Callable[[Preprocessing], IdentificationModel]) -> tuple[dict, str]:
    """The pre-processing changes (cut-off, and the decimation when the data chose it) at which
    the dynamic law of ``model`` with the parameters ``x`` predicts each joint's effort best (module
    doc), and why; {} when its cut-offs are already those. ``settings``: the request's (what the
    rule chooses is None there); ``rebuild(settings)``: the model on other settings."""
    pre, chosen = model.obs.preprocessing, model.obs.report.get("from_data", [])
    if "cutoff_hz" not in chosen or pre.filter == "none":
        return {}, ""
    fs = model.obs.report["sample_rate_hz"]
    obs = model.obs
    data_joints = list(obs.data_joints or obs.joints)
    # each row joint's data joints: itself, or those a motor turns with
    rows_of = ([[j] for j in range(len(data_joints))] if obs.coupling is None
               else [list(np.flatnonzero(obs.coupling[m] != 0.0)) for m in range(len(obs.joints))])
    fixed = {"trim_start_s": pre.trim_start_s, "trim_end_s": pre.trim_end_s}  # the same instants for each
    candidates = candidate_cutoffs(model)
    rms = [joint_rms(model, x)]  # the current cut-offs: the model itself
    for cut in candidates[1:]:  # upwards until no joint predicts better by more than the tolerance
        changes = {**fixed, "cutoff_hz": cut}
        if "decimate" in chosen:
            changes["decimate"] = rule_decimation(fs, cut)
        rms.append(joint_rms(rebuild(replace(settings, **changes)), x))
        if np.all(rms[-1] >= (1.0 - PREDICTION_TOLERANCE) * np.min(rms[:-1], axis=0)):
            break
    candidates = candidates[: len(rms)]
    rms = np.array(rms)  # (candidates, row joints)
    pick = np.argmax(rms <= (1.0 + PREDICTION_TOLERANCE) * rms.min(axis=0, keepdims=True), axis=0)
    best = {}
    for m, k in enumerate(pick):
        for j in rows_of[m]:
            best[data_joints[j]] = max(best.get(data_joints[j], 0.0), candidates[k][data_joints[j]])
    current = candidates[0]
    if all(best[j] <= current[j] * (1 + 1e-9) for j in best):
        return {}, ""
    changes = {**fixed, "cutoff_hz": {j: best.get(j, current[j]) for j in current}}
    if "decimate" in chosen:
        changes["decimate"] = rule_decimation(fs, changes["cutoff_hz"])
    raised = ", ".join(f"{j} {current[j]:.3g} → {changes['cutoff_hz'][j]:.3g} Hz" for j in current
                       if changes["cutoff_hz"][j] > current[j] * (1 + 1e-9))
    why = (f"the {model.friction.label} fit predicts the effort best at higher cut-offs than the rule's "
           f"({raised}; RMS residual within {PREDICTION_TOLERANCE:.0%} of its best)")
    return changes, why


def presliding_model(model: IdentificationModel, x: np.ndarray, settings: Preprocessing,
                     rebuild: Callable[[Preprocessing], IdentificationModel]) -> IdentificationModel:
    """``model`` (of a dynamic law, on data its rule chose the settings for) at the rates at which
    the parameters ``x`` predict these data's effort best (:func:`presliding_changes`)."""
    changes, why = presliding_changes(model, x, settings, rebuild)
    if not changes:
        return model
    out = rebuild(replace(settings, **changes))
    out.obs.report["from_data"] = sorted(set(model.obs.report.get("from_data", [])) | {"cutoff_hz"})
    out.obs.report["presliding_rates"] = why
    return out
