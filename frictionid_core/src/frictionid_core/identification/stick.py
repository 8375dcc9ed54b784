"""Stick phases: where a joint sticks (or creeps) at low speed, its friction is below its sliding
level, which no friction law of the fit explains; those rows are left out (:func:`exclude_stick_phases`).

Detection per row joint, on a Coulomb least-squares fit of the same rows (rigid body, viscous,
Coulomb, offset): each row's *dry friction* is what the fit leaves unexplained once its Coulomb
term is removed, sign(q̇)·(y − ŷ + Fc·S); away from a reversal's anti-alias transient (|S| ≥
0.9, S the decimated sign column) it estimates the joint's Coulomb level Fc. The rows are sorted
by |q̇| and binned (STICK_BIN_SHARE of them, at least STICK_BIN_ROWS); starting from the slowest,
every bin whose median dry friction is below (1 − STICK_TOLERANCE)·Fc and 3 σ of its median sticks;
the candidate stick speed is the fastest row of the last such bin.

A stick phase is a band with a knee: the fit is repeated without the rows below the candidate
speeds (they biased Fc low), and the joint sticks only where, at that refit level, the dry friction
of the rows between STICK_KNEE × the candidate speed and twice that is back at its level (median
within STICK_TOLERANCE). A friction that rises gradually out of standstill (a real gear's Fs < Fc,
or a dip above Fc) is the friction law's shape, not a stick phase: its deficit goes on above the
band, and its rows stay. The candidates are refit until their speeds settle: the level rises a
little as a band's rows leave, and the band with it; a band that still widens after STICK_ROUNDS
refits follows the level up — the law's shape again — and is no stick phase either.

Only for a friction law without a dip (Coulomb: a law with a dip models friction below its level at
low speed, its Fs < Fc, warned), and when the min speed is chosen from the data (a ``--min-speed``
given is the user's choice).
The rows are left out of the observation in place (:func:`leave_out_stick_rows`): the same rows a
rebuild with ``Preprocessing.stick_speed`` leaves out, without a second pre-processing.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import get_model
from frictionid_core.model import IdentificationModel, Observation
from frictionid_core.preprocess import REVERSAL_PERIODS, Preprocessing
from frictionid_core.systems import exclude_rows, reversal_rows

STICK_BIN_SHARE = 0.01  # rows per speed bin, as a share of the joint's rows …
STICK_BIN_ROWS = 50  # … and at least this many
STICK_TOLERANCE = 0.05  # a bin sticks when its median dry friction is this far below the level (and 3 σ)
STICK_SIGN = 0.9  # rows with |S| below this lie in a reversal's anti-alias transient: not judged
STICK_KNEE = 2.0  # the friction is back at its level between this × the stick speed and twice that
STICK_SLIDING_SHARE = 0.2  # the first fit leaves out this share of each joint's slowest rows: its level is sliding
STICK_TOP_SHARE = 0.05  # a stick band lies below this share of the joint's top speed (99th percentile of |q̇|)
STICK_ROUNDS = 4  # at most this many refits until the stick speeds settle
STICK_SETTLED = 0.05  # … settled when no speed moves by more than this share
# Friction parameters of other laws than Coulomb (their user bounds and fixed values do not apply to it).
_NOT_COULOMB = ("Fs", "vs", "delta", "v0")

REVERSAL_REASON = ("rows within reversal_periods periods of the joint's cut-off of one of its reversals (or a stop or "
                   "a start): the filter spreads the stick or slip there over that time, so the filtered acceleration "
                   "and sign of motion misstate those rows for a law without a dip")
STICK_REASON = ("rows slower than the joint's stick speed, where the friction the fit leaves unexplained stays below "
                "its Coulomb level and is back at it just above (the joint sticks or creeps at reversals; no "
                "friction law of the fit models that)")


def exclude_stick_phases(model: IdentificationModel, settings: Preprocessing
                         ) -> tuple[IdentificationModel, Preprocessing]:
    """``model`` and ``settings`` with the stick phases of ``model.obs`` left out (``stick_speed``
    set in both, the rows left out of the observation in place and the model rebuilt on it), then
    the rows within :data:`~frictionid_core.preprocess.REVERSAL_PERIODS` periods of each joint's
    cut-off of its reversals (``reversal_periods``, unless given); neither when the law has a dip or
    the min speed is not chosen from the data (``reversal_periods`` 0 then, unless given). The
    observation's report gets ``stick_rows``, ``stick_reason``, ``reversal_rows`` and
    ``reversal_reason``."""
    chosen = settings.reversal_periods is None  # else given: the observation has applied it
    if model.friction.law.nonlinear or "min_speed" not in model.obs.report.get("from_data", []):
        if not chosen:
            return model, settings
        leave_out_reversal_rows(model.obs, 0.0)
        return replace(model), replace(settings, reversal_periods=0.0)
    speeds = stick_speeds(model)
    if speeds:
        leave_out_stick_rows(model.obs, speeds)
        model.obs.report["stick_reason"] = STICK_REASON
        settings = replace(settings, stick_speed=speeds)
    if chosen:
        leave_out_reversal_rows(model.obs, REVERSAL_PERIODS)
        settings = replace(settings, reversal_periods=REVERSAL_PERIODS)
    return replace(model), settings


def leave_out_reversal_rows(obs: Observation, periods: float) -> None:
    """Leave the rows of ``obs`` (and of its sampled observation) within ``periods`` periods of
    their joint's cut-off of its reversals out (:func:`frictionid_core.systems.system.reversal_rows`:
    the rows a rebuild with ``reversal_periods`` leaves out), count them in the report
    (``reversal_rows``, and in ``slow_rows_excluded``) and set ``reversal_periods``."""
    used = obs.used.reshape(len(obs.joints), obs.n_samples).T
    near = used & reversal_rows(obs, ~used, replace(obs.preprocessing, reversal_periods=periods))
    for o in (obs, obs.sampled):
        if o is not None:
            exclude_rows(o, near if o is obs else near[np.searchsorted(obs.t, o.t)])
            o.preprocessing = replace(o.preprocessing, reversal_periods=periods)
    report = obs.report
    counts = dict(zip(obs.joints, map(int, near.sum(axis=0))))
    report["reversal_rows"] = {j: report.get("reversal_rows", {}).get(j, 0) + n for j, n in counts.items()}
    report["slow_rows_excluded"] = {j: report["slow_rows_excluded"].get(j, 0) + n for j, n in counts.items()}
    if periods:
        report["reversal_reason"] = REVERSAL_REASON


def leave_out_stick_rows(obs: Observation, speeds: dict[str, float]) -> None:
    """Leave the rows of ``obs`` (and of its sampled observation) slower than ``speeds`` ({row joint:
    speed}) out, as :func:`frictionid_core.systems.system.exclude_rows` does for slow rows; count
    them in the report (``stick_rows``, and in ``slow_rows_excluded``) and set ``stick_speed``."""
    limit = np.array([speeds.get(j, 0.0) for j in obs.joints])
    used = obs.used.reshape(len(obs.joints), obs.n_samples).T
    stick = used & (np.abs(obs.velocity) < limit)
    sampled = obs.sampled
    for o in (obs, sampled):
        if o is not None:
            exclude_rows(o, stick if o is obs else stick[np.searchsorted(obs.t, o.t)])
            o.preprocessing = replace(o.preprocessing, stick_speed=dict(speeds))
    report = obs.report
    counts = dict(zip(obs.joints, map(int, stick.sum(axis=0))))
    report["stick_rows"] = {j: report.get("stick_rows", {}).get(j, 0) + n for j, n in counts.items()}
    report["slow_rows_excluded"] = {j: report["slow_rows_excluded"].get(j, 0) + n for j, n in counts.items()}


def stick_speeds(model: IdentificationModel) -> dict[str, float]:
    """{row joint: stick speed} of the joints of ``model.obs`` that stick (see the module doc)."""
    obs = model.obs
    try:
        coulomb = model if model.friction.name == "coulomb" else coulomb_model(model, obs)
        x = coulomb_fit(coulomb)
    except FrictionIdError:  # the user's bounds or fixed values do not fit a Coulomb law
        return {}
    slowest = obs.report.get("min_speed_rows", {})
    used = obs.used.reshape(len(obs.joints), obs.n_samples)
    sliding, top = {}, {}
    for j, joint in enumerate(obs.joints):
        if used[j].any():
            sliding[joint], top[joint] = np.quantile(np.abs(obs.velocity[used[j], j]), [STICK_SLIDING_SHARE, 0.99])
    x = coulomb_fit(coulomb_model(model, without_rows(obs, sliding)))  # the sliding level
    first = {}
    for joint in sliding:
        speed, share = dry_friction(coulomb, x, obs.joints.index(joint))
        v = band_speed(speed, share)
        if slowest.get(joint, 0.0) < v <= STICK_TOP_SHARE * top[joint] and regains_level(speed, share, v):
            first[joint] = v
    speeds, settled = dict(first), set()
    for _ in range(STICK_ROUNDS):
        if not speeds or settled >= speeds.keys():
            break
        x = coulomb_fit(coulomb_model(model, without_rows(obs, speeds)))
        found = {}
        for joint, v in speeds.items():
            speed, share = dry_friction(coulomb, x, obs.joints.index(joint))
            if regains_level(speed, share, v):
                found[joint] = max(band_speed(speed, share), slowest.get(joint, 0.0))
        settled = {j for j, v in found.items() if abs(v - speeds[j]) <= STICK_SETTLED * speeds[j]}
        speeds = {j: v for j, v in found.items() if v > slowest.get(j, 0.0)}
    return {j: v for j, v in speeds.items() if j in settled and v <= STICK_TOP_SHARE * top[j]}


def coulomb_model(model: IdentificationModel, obs: Observation) -> IdentificationModel:
    """A Coulomb model (rigid body, Fv, Fc, offset as ``model``) on ``obs`` with the user's bounds and
    fixed values of ``model`` that apply to it."""
    def applies(key: str) -> bool:
        return key.rsplit("/", 1)[-1].removesuffix("_pos").removesuffix("_neg") not in _NOT_COULOMB

    return IdentificationModel(obs, get_model("coulomb", model.friction.asymmetric), offset=model.offset,
                               rigid_bounds=model.rigid_bounds,
                               bound_overrides={k: v for k, v in model.bound_overrides.items() if applies(k)},
                               fixed={k: v for k, v in model.fixed.items() if applies(k)})


def coulomb_fit(coulomb: IdentificationModel) -> np.ndarray:
    """The least-squares parameters (k,) of a Coulomb model, from its normal equations (within the
    user's bounds, at the fixed values; a tiny ridge for collinear columns: the fit's own rank
    check comes later)."""
    return coulomb.solve_linear(np.zeros((1, coulomb.k)))[0][0]


def dry_friction(coulomb: IdentificationModel, x: np.ndarray, j: int) -> tuple[np.ndarray, np.ndarray]:
    """(|q̇|, dry friction / level) of the judged rows of row joint j under the Coulomb fit ``x`` of
    ``coulomb`` (see the module doc; none where the level is not positive)."""
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
    return np.abs(v[judged]), (np.sign(v[judged]) * unexplained[judged] / np.abs(s[judged])) / level[judged]


def _bin_size(rows: int) -> int:
    return max(STICK_BIN_ROWS, int(np.ceil(STICK_BIN_SHARE * rows)))


def _below_level(values: np.ndarray) -> bool:
    """True when the median of ``values`` (dry friction / level) lies clearly below the level."""
    median = np.median(values)
    sigma = 1.2533 * 1.4826 * np.median(np.abs(values - median)) / np.sqrt(values.size)
    return bool(median < 1.0 - max(STICK_TOLERANCE, 3.0 * sigma))


def band_speed(speed: np.ndarray, share: np.ndarray) -> float:
    """The fastest row of the slowest bins (by |q̇|) whose dry friction stays below its level; 0
    when the slowest bin is at the level or there are too few rows to judge."""
    if speed.size < 2 * STICK_BIN_ROWS:
        return 0.0
    order = np.argsort(speed)
    size = _bin_size(order.size)
    stick = 0.0
    for start in range(0, order.size - size + 1, size):
        rows_in = order[start : start + size]
        if not _below_level(share[rows_in]):
            break
        stick = float(speed[rows_in].max())
    return stick


def regains_level(speed: np.ndarray, share: np.ndarray, stick: float) -> bool:
    """True when the dry friction of the rows between STICK_KNEE × ``stick`` and twice that is back
    at its level (median within STICK_TOLERANCE): a stick band's knee; False with too few rows there."""
    above = share[(speed > STICK_KNEE * stick) & (speed <= 2 * STICK_KNEE * stick)]
    return above.size >= STICK_BIN_ROWS and bool(np.median(above) >= 1.0 - STICK_TOLERANCE)


def without_rows(obs: Observation, speeds: dict[str, float]) -> Observation:
    """A copy of ``obs`` (without its sampled rows) with the rows slower than ``speeds`` left out."""
    copy = replace(obs, y=obs.y.copy(), rigid=obs.rigid.copy(), velocity=obs.velocity.copy(),
                   columns=[{k: c.copy() for k, c in cols.items()} for cols in obs.columns], used=obs.used.copy(),
                   sampled=None)
    limit = np.array([speeds.get(j, 0.0) for j in obs.joints])
    exclude_rows(copy, np.abs(obs.velocity) < limit)
    return copy
