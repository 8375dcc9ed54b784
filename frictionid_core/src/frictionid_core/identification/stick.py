"""Stick phases: where a joint sticks (or creeps) at low speed, its friction is below its sliding
level, which no friction law of the fit explains; those rows are left out (:func:`exclude_stick_phases`).

Detection per row joint, on a Coulomb least-squares fit of the same rows (rigid body, viscous,
Coulomb, offset): each row's *dry friction* is what the fit leaves unexplained once its Coulomb
term is removed, sign(q̇)·(y − ŷ + Fc·S); away from a reversal's anti-alias transient (|S| ≥
0.9, S the decimated sign column) it estimates the joint's Coulomb level Fc. The rows are sorted
by |q̇| and binned (STICK_BIN_SHARE of them, at least STICK_BIN_ROWS); starting from the slowest,
every bin whose median dry friction is below (1 − STICK_TOLERANCE)·Fc and 3 σ of its median sticks;
the stick speed is the fastest row of the last such bin. The fit is repeated without the rows
found (their biased Fc moved the level) until the speeds settle. A friction that rises out of
standstill (a Stribeck dip above Fc) sticks nowhere: its low-speed rows lie above the level.

Only when the min speed is chosen from the data (a ``--min-speed`` given is the user's choice).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_core.identification_model import IdentificationModel
from frictionid_core.observation import Observation
from frictionid_core.preprocess import Preprocessing

STICK_BIN_SHARE = 0.01  # rows per speed bin, as a share of the joint's rows …
STICK_BIN_ROWS = 50  # … and at least this many
STICK_TOLERANCE = 0.05  # a bin sticks when its median dry friction is this far below the level (and 3 σ)
STICK_SIGN = 0.9  # rows with |S| below this lie in a reversal's anti-alias transient: not judged
STICK_ROUNDS = 4  # at most this many fits until the stick speeds settle
STICK_SETTLED = 0.05  # … settled when no speed moves by more than this share
# Friction parameters of other laws than Coulomb (their user bounds and fixed values do not apply to it).
_NOT_COULOMB = ("Fs", "vs", "delta", "v0")

STICK_REASON = ("rows slower than the joint's stick speed, where the friction the fit leaves unexplained stays below "
                "its Coulomb level (the joint sticks or creeps at reversals; no friction law of the fit models that)")


def exclude_stick_phases(model: IdentificationModel, settings: Preprocessing,
                         rebuild: Callable[[Preprocessing], IdentificationModel]
                         ) -> tuple[IdentificationModel, Preprocessing]:
    """``model`` and ``settings`` with the stick phases of ``model.obs`` left out (``stick_speed``
    set, the model rebuilt), or both unchanged when the min speed is not chosen from the data or
    no joint sticks. The report of the rebuilt observation gets ``stick_reason``."""
    if "min_speed" not in model.obs.report.get("from_data", []):
        return model, settings
    speeds = stick_speeds(model)
    if not speeds:
        return model, settings
    settings = replace(settings, stick_speed=speeds)
    from_data = model.obs.report["from_data"]
    model = rebuild(settings)
    model.obs.report["from_data"] = from_data
    model.obs.report["stick_reason"] = STICK_REASON
    return model, settings


def stick_speeds(model: IdentificationModel) -> dict[str, float]:
    """{row joint: stick speed} of the joints of ``model.obs`` that stick (see the module doc)."""
    obs = model.obs
    try:
        coulomb = coulomb_model(model, obs)
    except FrictionIdError:  # the user's bounds or fixed values do not fit a Coulomb law
        return {}
    speeds: dict[str, float] = {}
    for _ in range(STICK_ROUNDS):
        try:
            fitted = coulomb if not speeds else coulomb_model(model, without_rows(obs, speeds))
            x, _, _ = fitted.fit_linear()
        except FrictionIdError:  # rank-deficient rows (a joint moving one way): the fit says why
            return {}
        found = {}
        for j, joint in enumerate(obs.joints):
            v = joint_stick_speed(coulomb, x, j)
            if v > obs.report.get("min_speed_rows", {}).get(joint, 0.0):
                found[joint] = v
        settled = found.keys() == speeds.keys() and all(
            abs(found[j] - speeds[j]) <= STICK_SETTLED * speeds[j] for j in found)
        speeds = found
        if settled or not found:
            break
    return speeds


def coulomb_model(model: IdentificationModel, obs: Observation) -> IdentificationModel:
    """A Coulomb model (rigid body, Fv, Fc, offset as ``model``) on ``obs`` with the user's bounds and
    fixed values of ``model`` that apply to it."""
    def applies(key: str) -> bool:
        return key.rsplit("/", 1)[-1].removesuffix("_pos").removesuffix("_neg") not in _NOT_COULOMB

    return IdentificationModel(obs, get_model("coulomb", model.friction.asymmetric), offset=model.offset,
                               rigid_bounds=model.rigid_bounds,
                               bound_overrides={k: v for k, v in model.bound_overrides.items() if applies(k)},
                               fixed={k: v for k, v in model.fixed.items() if applies(k)})


def joint_stick_speed(coulomb: IdentificationModel, x: np.ndarray, j: int) -> float:
    """The stick speed of row joint j under the Coulomb fit ``x`` of ``coulomb`` (0: it does not stick)."""
    obs = coulomb.obs
    nd = obs.n_samples
    prefix = f"{obs.joints[j]}/" if len(obs.joints) > 1 else ""
    levels = [i for i, n in enumerate(coulomb.names) if n.startswith(prefix) and n[len(prefix):].startswith("Fc")]
    dry_free = x.copy()
    dry_free[levels] = 0.0
    rows = slice(j * nd, (j + 1) * nd)
    unexplained = obs.y[rows] - coulomb.predict(dry_free)[rows]
    v, s = obs.velocity[:, j], obs.columns[j]["S"]
    judged = obs.used[rows] & (np.abs(s) >= STICK_SIGN)
    if coulomb.friction.asymmetric:
        level = np.where(v > 0, x[levels[0]], x[levels[1]])
    else:
        level = np.full(nd, x[levels[0]])
    judged &= level > 0
    if judged.sum() < 2 * STICK_BIN_ROWS:
        return 0.0
    speed = np.abs(v[judged])
    share = (np.sign(v[judged]) * unexplained[judged] / np.abs(s[judged])) / level[judged]  # dry friction / level
    order = np.argsort(speed)
    size = max(STICK_BIN_ROWS, int(np.ceil(STICK_BIN_SHARE * order.size)))
    stick = 0.0
    for start in range(0, order.size - size + 1, size):
        rows_in = order[start : start + size]
        values = share[rows_in]
        median = np.median(values)
        sigma = 1.2533 * 1.4826 * np.median(np.abs(values - median)) / np.sqrt(size)
        if median >= 1.0 - max(STICK_TOLERANCE, 3.0 * sigma):
            break
        stick = float(speed[rows_in].max())
    return stick


def without_rows(obs: Observation, speeds: dict[str, float]) -> Observation:
    """A copy of ``obs`` (without its sampled rows) with the rows slower than ``speeds`` left out."""
    from frictionid_core.systems.system import exclude_rows

    copy = replace(obs, y=obs.y.copy(), rigid=obs.rigid.copy(), velocity=obs.velocity.copy(),
                   columns=[{k: c.copy() for k, c in cols.items()} for cols in obs.columns], used=obs.used.copy(),
                   sampled=None)
    limit = np.array([speeds.get(j, 0.0) for j in obs.joints])
    exclude_rows(copy, np.abs(obs.velocity) < limit)
    return copy
